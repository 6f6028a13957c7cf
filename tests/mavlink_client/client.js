// A MAVLink 2 ground station Rejuv did not write (node-mavlink, docs/mavlink.md), driven against `rejuv run`
// by tests/multiproc/mavlink_client_test.cpp. It talks to the kernel's network gate over UDP and, within
// --timeout seconds of wall-clock time:
//   1. sends HEARTBEATs (MAV_TYPE_GCS) and waits for the vehicle's HEARTBEAT (MAV_TYPE_QUADROTOR);
//   2. with --wrong-key, sends an unsigned, a wrongly signed and a recorded MISSION_COUNT (signed with --key
//      but stamped in January 2015) every 100 ms and on the vehicle's messages (the gate must refuse all three:
//      the test checks its counters in the run summary);
//   3. from the start, uploads a one-waypoint mission (MAV_FRAME_LOCAL_NED) with the mission protocol, retransmitting its
//      last message every --retry-ms without an answer (the gate drops everything in the secure execution
//      interval) and starting again on MAV_MISSION_INVALID_SEQUENCE (a rollback ended the transaction);
//   4. watches LOCAL_POSITION_NED until the vehicle is near the uploaded waypoint, and STATUSTEXT until one
//      reports a rollback.
// Prints a JSON summary on stdout; exit 0 when every step was seen, 1 otherwise.
//   node client.js --port P [--key HEX] [--wrong-key HEX] [--timeout S] [--retry-ms MS] [--target N,E,D]
'use strict';
const dgram = require('dgram');
const { PassThrough } = require('stream');
const { MavLinkProtocolV2, MavLinkPacketSplitter, MavLinkPacketParser, minimal, common } = require('node-mavlink');

const args = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 && i + 1 < args.length ? args[i + 1] : fallback;
};
const port = Number(opt('--port', '0'));
const key = opt('--key', null) ? Buffer.from(opt('--key'), 'hex') : null;
const wrongKey = opt('--wrong-key', null) ? Buffer.from(opt('--wrong-key'), 'hex') : null;
const timeoutS = Number(opt('--timeout', '60'));
const retryMs = Number(opt('--retry-ms', '20'));
const target = opt('--target', '-0.6,-0.4,-3.3').split(',').map(Number);
if (!port) {
  console.error('client.js: --port P is required');
  process.exit(2);
}

const GCS_SYSID = 255, GCS_COMPID = 190, LINK_ID = 1;
const MAV_MISSION_ACCEPTED = 0, MAV_MISSION_INVALID_SEQUENCE = 13, MAV_MISSION_OPERATION_CANCELLED = 15;
const socket = dgram.createSocket('udp4');
const report = {
  heartbeat: false, vehicle_type: null, refusal_probes_sent: 0, upload_ack: null, upload_restarts: 0,
  upload_transmissions: 0, upload_unanswered: null, distance_at_ack_m: null, min_distance_after_ack_m: null, reached_target: false,
  rollback_statustext: null, statustexts: 0, local_position_ned: 0,
};

let seq = 0;
let lastSignMs = 0;
function frame(msg, signKey) {
  const protocol = new MavLinkProtocolV2(GCS_SYSID, GCS_COMPID, signKey ? MavLinkProtocolV2.IFLAG_SIGNED : 0);
  let b = protocol.serialize(msg, seq);
  seq = (seq + 1) & 255;
  if (signKey) {
    // node-mavlink's timestamp has 1 ms resolution: one millisecond more per frame keeps it increasing.
    lastSignMs = Math.max(Date.now(), lastSignMs + 1);
    b = protocol.sign(b, LINK_ID, signKey, lastSignMs);
  }
  return b;
}
// A frame of a recording: signed with the key, stamped from 2015-01-01 00:00 UTC on (the signing epoch), one
// millisecond more each time, as a flight recorded then and played back now.
let recordedMs = Date.UTC(2015, 0, 1);
function recordedFrame(msg) {
  const protocol = new MavLinkProtocolV2(GCS_SYSID, GCS_COMPID, MavLinkProtocolV2.IFLAG_SIGNED);
  const b = protocol.serialize(msg, seq);
  seq = (seq + 1) & 255;
  recordedMs += 1;
  return protocol.sign(b, LINK_ID, key, recordedMs);
}
function send(msg, signKey = key) {
  socket.send(frame(msg, signKey), port, '127.0.0.1');
}

function heartbeat() {
  const hb = new minimal.Heartbeat();
  hb.type = 6; hb.autopilot = 8; hb.baseMode = 0; hb.customMode = 0; hb.systemStatus = 4; hb.mavlinkVersion = 3;
  return hb;
}
function missionCount() {
  const m = new common.MissionCount();
  m.targetSystem = 1; m.targetComponent = 1; m.count = 1; m.missionType = 0; m.opaqueId = 0;
  return m;
}
function missionItem(seqNo) {
  const item = new common.MissionItemInt();
  item.targetSystem = 1; item.targetComponent = 1; item.seq = seqNo; item.frame = 1; item.command = 16;
  item.current = seqNo === 0 ? 1 : 0; item.autocontinue = 1;
  item.param1 = 0; item.param2 = 0.1; item.param3 = 0; item.param4 = 0;
  item.x = Math.round(target[0] * 1e4); item.y = Math.round(target[1] * 1e4); item.z = target[2];
  item.missionType = 0;
  return item;
}

// Incoming datagrams through node-mavlink's own splitter and parser.
const input = new PassThrough();
const packets = input.pipe(new MavLinkPacketSplitter()).pipe(new MavLinkPacketParser());
socket.on('message', (buf) => input.write(buf));

let phase = 'start';  // upload → watch (or done: refused)
let lastUpload = null;    // the last upload message (retransmitted without an answer)
let lastUploadAt = 0;
function uploadSend(msg) {
  lastUpload = msg;
  lastUploadAt = Date.now();
  report.upload_transmissions += 1;
  send(msg);
}
function startUpload() {
  phase = 'upload';
  uploadSend(missionCount());
}

// The refusal probes: an unsigned, a wrongly signed and a recorded MISSION_COUNT.
let lastProbeAt = 0;
function probe() {
  lastProbeAt = Date.now();
  send(missionCount(), null);
  send(missionCount(), wrongKey);
  report.refusal_probes_sent += 2;
  if (key) {
    socket.send(recordedFrame(missionCount()), port, '127.0.0.1');
    report.refusal_probes_sent += 1;
  }
}

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };
packets.on('data', (packet) => {
  // The vehicle speaks only outside the secure execution interval, where the gate checks a frame's signature
  // instead of dropping it: a probe now reaches the check. (In lockstep at 10× real time an MC window lasts
  // tens of ms of wall-clock time: probes on a 100 ms clock alone can miss every window.)
  if (wrongKey && Date.now() - lastProbeAt >= 20) probe();
  const clazz = REGISTRY[packet.header.msgid];
  if (!clazz) return;
  const data = packet.protocol.data(packet.payload, clazz);
  if (clazz === minimal.Heartbeat) {
    if (!report.heartbeat) {
      report.heartbeat = true;
      report.vehicle_type = data.type;

    }
  } else if (clazz === common.MissionRequestInt && phase === 'upload') {
    if (report.upload_unanswered === null) report.upload_unanswered = report.upload_transmissions - 1;
    if (data.seq === 0) uploadSend(missionItem(0));
  } else if (clazz === common.MissionAck && phase === 'upload') {
    if (data.type === MAV_MISSION_INVALID_SEQUENCE || data.type === MAV_MISSION_OPERATION_CANCELLED) {
      report.upload_restarts += 1;
      uploadSend(missionCount());
    } else {
      report.upload_ack = data.type;
      phase = data.type === MAV_MISSION_ACCEPTED ? 'watch' : 'done';
    }
  } else if (clazz === common.LocalPositionNed) {
    report.local_position_ned += 1;
    const d = Math.hypot(data.x - target[0], data.y - target[1], data.z - target[2]);
    if (phase === 'watch') {
      if (report.distance_at_ack_m === null) report.distance_at_ack_m = d;
      report.min_distance_after_ack_m = Math.min(report.min_distance_after_ack_m ?? d, d);
      if (d < 0.3) report.reached_target = true;
    }
  } else if (clazz === common.StatusText) {
    report.statustexts += 1;
    const text = String(data.text).replace(/\0.*$/, '');
    if (text.startsWith('SR rollback') && report.rollback_statustext === null) report.rollback_statustext = text;
  }
  maybeFinish();
});

function complete() {
  return report.heartbeat && report.upload_ack === MAV_MISSION_ACCEPTED && report.reached_target &&
         report.rollback_statustext !== null && (!wrongKey || report.refusal_probes_sent >= 20);
}
function finish(code) {
  console.log(JSON.stringify(report));
  socket.close();
  process.exit(code);
}
function maybeFinish() {
  if (complete()) finish(0);
  if (phase === 'done') finish(1);
}

socket.on('error', () => {});  // nobody listening yet (the kernel still booting): the retransmissions cover it
socket.bind(0, '127.0.0.1', () => {
  const started = Date.now();
  // The upload starts at once, before the vehicle has been heard: `rejuv run` spends its pre-flight
  // alignment in the secure execution interval, where the gate drops everything, so the first transmissions
  // are lost and the retransmissions carry the upload into the first MC window.
  startUpload();
  setInterval(() => {
    const now = Date.now();
    if (now - started > timeoutS * 1000) finish(1);
    // HEARTBEAT: fast until the vehicle answers (it only may in MC), then at 1 Hz as a ground station does.
    if (!report.heartbeat || now % 1000 < 20) send(heartbeat());
    if (phase === 'upload' && lastUpload && now - lastUploadAt >= retryMs) uploadSend(lastUpload);
    // With --wrong-key, all along (so that some arrive in MC, where the gate checks rather than drops): an
    // unsigned, a wrongly signed and a recorded MISSION_COUNT. The gate refuses them; ext_link never sees them.
    if (wrongKey && report.heartbeat && now % 100 < 20) probe();
  }, 20);
});
