// The codec's message definitions (kernel_sim/mavlink, written as JSON by tests/unit/mavlink/registry_test.cpp)
// against node-mavlink's registry, generated from the protocol's own XML: for every message the project
// encodes or decodes, the id, the name, each field in wire order (name, type, array length), which fields are
// extensions, the payload length and CRC_EXTRA. Prints one line per disagreement and a JSON summary last;
// exit 0 when everything agrees, 1 otherwise, 2 on bad usage.
//   node registry_check.js CODEC.json
'use strict';
const fs = require('fs');
const { minimal, common, standard } = require('node-mavlink');

if (process.argv.length !== 3) {
  console.error('registry_check.js: usage: node registry_check.js CODEC.json');
  process.exit(2);
}
const codec = JSON.parse(fs.readFileSync(process.argv[2], 'utf8'));
const REGISTRY = { ...minimal.REGISTRY, ...standard.REGISTRY, ...common.REGISTRY };
const problems = [];
let fieldsCompared = 0;
for (const m of codec.messages) {
  const clazz = REGISTRY[m.id];
  if (!clazz) { problems.push(`${m.name} (${m.id}): not in node-mavlink's registry`); continue; }
  const where = `${m.name} (${m.id})`;
  if (clazz.MSG_NAME !== m.name) problems.push(`${where}: node-mavlink names it ${clazz.MSG_NAME}`);
  if (clazz.MAGIC_NUMBER !== m.crc_extra) problems.push(`${where}: CRC_EXTRA ${m.crc_extra}, node-mavlink ${clazz.MAGIC_NUMBER}`);
  if (clazz.PAYLOAD_LENGTH !== m.payload_bytes) {
    problems.push(`${where}: ${m.payload_bytes} payload bytes, node-mavlink ${clazz.PAYLOAD_LENGTH}`);
  }
  const theirs = clazz.FIELDS;
  if (theirs.length !== m.fields.length) {
    problems.push(`${where}: ${m.fields.length} fields, node-mavlink ${theirs.length}`);
  }
  for (let i = 0; i < Math.min(theirs.length, m.fields.length); ++i) {
    const ours = m.fields[i];
    const f = theirs[i];
    // node-mavlink writes an array's type as "T[]" with its length apart, and HEARTBEAT's mavlink_version with
    // the XML's special type uint8_t_mavlink_version, which is a uint8_t on the wire and in CRC_EXTRA.
    const type = f.type.replace('[]', '').replace('uint8_t_mavlink_version', 'uint8_t');
    const length = f.type.endsWith('[]') ? f.length : 0;
    fieldsCompared += 1;
    if (f.source !== ours.name) problems.push(`${where}: field ${i} is ${ours.name}, node-mavlink ${f.source}`);
    if (type !== ours.type) problems.push(`${where}.${ours.name}: type ${ours.type}, node-mavlink ${type}`);
    if (length !== ours.length) problems.push(`${where}.${ours.name}: array length ${ours.length}, node-mavlink ${length}`);
    if (Boolean(f.extension) !== ours.extension) {
      problems.push(`${where}.${ours.name}: ${ours.extension ? '' : 'not '}an extension here, node-mavlink says otherwise`);
    }
  }
}
for (const p of problems) console.log(p);
console.log(JSON.stringify({ messages: codec.messages.length, fields: fieldsCompared, problems: problems.length }));
process.exit(problems.length === 0 ? 0 : 1);
