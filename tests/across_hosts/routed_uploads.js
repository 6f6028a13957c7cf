// Prints the `timestamp_ns` (the writer's stamp) and when the kernel routed it, in flight time [us] (the log's
// `timestamp` less the parameter `lockstep.alignment_s`: the clock of the run's CSVs, docs/ulog.md) of every
// mission_upload the vehicle's kernel routed, one per line, as a ULog of
// `rejuv run --ulog-profile full` holds them (a `D` message per routed message: docs/ulog.md), read with
// @foxglove/ulog (a reader Rejuv did not write; installed by ./rejuv's set-up into build/<preset>/ulog_reader).
// planner_test.cpp sets them against the vehicle's mode trace. Usage: node routed_uploads.js FILE.ulg
"use strict";

const { ULog, MessageType } = require("@foxglove/ulog");
const { FileReader } = require("@foxglove/ulog/node");

async function main() {
  const file = process.argv[2];
  if (!file) {
    console.error("usage: node routed_uploads.js FILE.ulg");
    process.exit(2);
  }
  const ulog = new ULog(new FileReader(file));
  await ulog.open();
  let subscribed = false;
  for (const [, sub] of ulog.subscriptions) if (sub.name === "mission_upload") subscribed = true;
  if (!subscribed) {
    console.error(`routed_uploads.js: ${file} has no mission_upload subscription`);
    process.exit(1);
  }
  const alignment = ulog.header.parameters.get("lockstep.alignment_s");
  if (!alignment) {
    console.error(`routed_uploads.js: ${file} has no parameter lockstep.alignment_s`);
    process.exit(1);
  }
  const alignmentUs = BigInt(Math.round(Number(alignment.value) * 1e6));
  const lines = [];
  for await (const msg of ulog.readMessages()) {
    if (msg.type !== MessageType.Data) continue;
    if (ulog.subscriptions.get(msg.msgId).name !== "mission_upload") continue;
    lines.push(`${msg.value.timestamp_ns} ${BigInt(msg.value.timestamp) - alignmentUs}`);
  }
  process.stdout.write(lines.map((l) => l + "\n").join(""));
}

main().catch((err) => {
  console.error(`routed_uploads.js: ${err && err.stack ? err.stack : err}`);
  process.exit(1);
});
