// Decodes CDR samples against the generated rejuv_msgs .msg files with readers Rejuv did not write: @foxglove/rosmsg
// parses the .msg text (as ROS 2 does: ros2 mode), @foxglove/rosmsg2-serialization reads the CDR (its 4-byte
// encapsulation header first). Prints one JSON object on stdout: each TYPE's decoded message, uint64 and int64
// values as decimal strings (exact), arrays as arrays. tests/ros2_msgs/ros2_names_test.cpp checks the values
// against what it wrote with Cyclone (docs/across_hosts.md "ROS 2 names").
// Usage: node decode_cdr.js MSG_DIR TYPE=SAMPLE.cdr...   (TYPE: a message of MSG_DIR, e.g. VehicleStateEstimate)
"use strict";

const fs = require("fs");
const path = require("path");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");

const kPackage = "rejuv_msgs";

function plain(value) {
  if (typeof value === "bigint") return value.toString();
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

// The message types a .msg's fields name (same package: the bare name; or rejuv_msgs/NAME).
function nested(text, names) {
  const out = [];
  for (const raw of text.split("\n")) {
    const line = raw.replace(/#.*/, "").trim();
    if (!line) continue;
    const type = line.split(/\s+/)[0].replace(/\[.*\]$/, "").replace(`${kPackage}/`, "");
    if (names.includes(type)) out.push(type);
  }
  return out;
}

// The definition of TYPE as a ROS 2 tool assembles it: its own .msg first, then each message it names,
// directly or not, after a separator and "MSG: rejuv_msgs/NAME".
function definition(dir, type) {
  const names = fs.readdirSync(dir).filter((f) => f.endsWith(".msg")).map((f) => f.slice(0, -4));
  if (!names.includes(type)) throw new Error(`no message ${type} in ${dir}`);
  const read = (name) => fs.readFileSync(path.join(dir, `${name}.msg`), "utf8");
  let text = read(type);
  const done = new Set([type]);
  const todo = nested(text, names);
  while (todo.length > 0) {
    const name = todo.shift();
    if (done.has(name)) continue;
    done.add(name);
    const own = read(name);
    text += `\n${"=".repeat(80)}\nMSG: ${kPackage}/${name}\n` + own;
    todo.push(...nested(own, names));
  }
  return parse(text, { ros2: true });
}

function main() {
  const [dir, ...samples] = process.argv.slice(2);
  if (!dir || samples.length === 0) {
    console.error("usage: node decode_cdr.js MSG_DIR TYPE=SAMPLE.cdr...");
    process.exit(2);
  }
  const out = {};
  for (const arg of samples) {
    const eq = arg.indexOf("=");
    const type = arg.slice(0, eq);
    const bytes = fs.readFileSync(arg.slice(eq + 1));
    const reader = new MessageReader(definition(dir, type));
    out[type] = plain(reader.readMessage(bytes));
  }
  process.stdout.write(JSON.stringify(out) + "\n");
}

main();
