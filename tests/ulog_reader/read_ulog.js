// Reads a ULog file with @foxglove/ulog (a reader Rejuv did not write) and prints a JSON summary on stdout:
// the info, parameters, formats, per-subscription message counts and timestamps (first, last, whether they
// never decrease), the logged strings, and a few field values. tests/ulog_reader/CMakeLists.txt checks it
// against `rejuv run`'s summary (docs/ulog.md). Usage: node read_ulog.js FILE.ulg
"use strict";

const { ULog, MessageType } = require("@foxglove/ulog");
const { FileReader } = require("@foxglove/ulog/node");

function plain(value) {
  if (typeof value === "bigint") return Number(value);
  if (Array.isArray(value)) return value.map(plain);
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

async function main() {
  const file = process.argv[2];
  if (!file) {
    console.error("usage: node read_ulog.js FILE.ulg");
    process.exit(2);
  }
  const ulog = new ULog(new FileReader(file));
  await ulog.open();
  const header = ulog.header;

  const topics = {};
  for (const [msgId, sub] of ulog.subscriptions) {
    topics[sub.name] = { msg_id: msgId, multi_id: sub.multiId, count: 0, first_us: null, last_us: null,
                         nondecreasing: true, first: null, last: null };
  }
  const logs = [];
  let previous = -1n;
  let ordered = true;
  for await (const msg of ulog.readMessages()) {
    if (msg.type === MessageType.Data) {
      const sub = ulog.subscriptions.get(msg.msgId);
      const t = topics[sub.name];
      const ts = msg.value.timestamp;
      if (ts < previous) ordered = false;
      previous = ts;
      if (t.last_us !== null && ts < BigInt(t.last_us)) t.nondecreasing = false;
      if (t.count === 0) {
        t.first_us = Number(ts);
        t.first = plain(msg.value);
      }
      t.count += 1;
      t.last_us = Number(ts);
      t.last = plain(msg.value);
    } else if (msg.type === MessageType.Log || msg.type === MessageType.LogTagged) {
      logs.push({ t_us: Number(msg.timestamp), level: msg.logLevel, text: msg.message });
    }
  }

  const range = ulog.timeRange();
  const summary = {
    version: header.version,
    info: plain(Object.fromEntries(header.information)),
    parameters: Object.fromEntries([...header.parameters].map(([k, v]) => [k, v.value])),
    formats: [...header.definitions.keys()],
    topics,
    data_messages: [...(ulog.dataMessageCounts() ?? new Map()).values()].reduce((a, b) => a + b, 0),
    log_count: ulog.logCount(),
    logs_first: logs.slice(0, 5),
    logs_matching: {
      checkpoint: logs.filter((l) => l.text.includes("checkpoint generation")).length,
      rollback: logs.filter((l) => l.text.includes("rollback to generation")).length,
      mode: logs.filter((l) => l.text.includes("sr: mode")).length,
    },
    time_range_us: range ? [Number(range[0]), Number(range[1])] : null,
    ordered,
  };
  process.stdout.write(JSON.stringify(summary, null, 1) + "\n");
}

main().catch((err) => {
  console.error(`read_ulog.js: ${err && err.stack ? err.stack : err}`);
  process.exit(1);
});
