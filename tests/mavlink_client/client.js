// A MAVLink 2 ground station Rejuv did not write (node-mavlink, docs/mavlink.md), driven against `rejuv run`
// by tests/multiproc/mavlink_client_test.cpp. It talks to the kernel's network gate over UDP and, within
// --timeout seconds of wall-clock time or until SIGTERM (a test of a lockstep run, whose vehicle time runs at
// whatever pace the machine allows, ends the client once the run is over instead):
//   1. sends HEARTBEATs (MAV_TYPE_GCS) and waits for the vehicle's HEARTBEAT (MAV_TYPE_QUADROTOR);
//   2. with --wrong-key, sends an unsigned, a wrongly signed and a recorded MISSION_COUNT (signed with --key
//      but stamped in January 2015) every 100 ms and on the vehicle's messages (the gate must refuse all three:
//      the test checks its counters in the run summary);
//   3. from the start, uploads a one-waypoint mission (MAV_FRAME_LOCAL_NED) with the mission protocol, retransmitting its
//      last message every --retry-ms without an answer (the gate drops everything in the secure execution
//      interval) and starting again on MAV_MISSION_INVALID_SEQUENCE (a rollback ended the transaction);
//   4. watches LOCAL_POSITION_NED until the vehicle is near the uploaded waypoint, and STATUSTEXT until one
//      reports a rollback;
//   with --qgc, as QGroundControl connects and plans: before the upload, COMMAND_LONG MAV_CMD_REQUEST_MESSAGE
//      for AUTOPILOT_VERSION and HOME_POSITION (answered COMMAND_ACK and the message), the whole parameter list
//      and a mission download; the upload in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT against the home learnt;
//      MISSION_ITEM_REACHED and GLOBAL_POSITION_INT within the acceptance radius of the waypoint; the mission
//      downloaded again (what was uploaded); MISSION_CLEAR_ALL (acknowledged; the vehicle holds at its setpoint)
//      and the mission downloaded once more (the one hold item); then MAV_CMD_NAV_RETURN_TO_LAUNCH and the
//      vehicle back over home.
//   With --key, every vehicle frame's signature is checked with node-mavlink (the gate signs them).
// Prints a JSON summary on stdout; exit 0 when every step was seen, 1 otherwise.
//   node client.js --port P [--key HEX] [--wrong-key HEX] [--timeout S] [--retry-ms MS] [--target N,E,D]
'use strict';
const dgram = require('dgram');
const { PassThrough } = require('stream');
const { MavLinkProtocolV2, MavLinkPacketSplitter, MavLinkPacketParser, minimal, common, standard } = require('node-mavlink');

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
const qgc = args.includes('--qgc');
const ACCEPTANCE_RADIUS_M = 0.3;
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
  vehicle_frames: 0, vehicle_frames_verified: 0,
  autopilot_version_capabilities: null, request_acks: {}, home: null, params: {}, param_types: {}, param_count: null,
  download_before: null, download_after: [], item_reached: [], min_global_distance_m: null, rtl_ack: null,
  min_home_distance_after_rtl_m: null, returned_home: false,
  clear_ack: null, download_after_clear: null, hold_offset_m: null,
};
const qgcSteps = ['version', 'home', 'params', 'download_before'];  // done before the upload, in order
let qgcStep = 0;
let downloadItems = [];
let downloadCount = null;

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
const EARTH_RADIUS_M = 6378137.0;
function latLonOf(north, east) {
  const lat = report.home.lat + north / EARTH_RADIUS_M * 180 / Math.PI;
  const lon = report.home.lon + east / (EARTH_RADIUS_M * Math.cos(report.home.lat * Math.PI / 180)) * 180 / Math.PI;
  return [lat, lon];
}
function missionItem(seqNo) {
  if (qgc) {
    // As QGroundControl plans: latitude, longitude [degE7] and altitude above home [m].
    const item = new common.MissionItemInt();
    const [lat, lon] = latLonOf(target[0], target[1]);
    item.targetSystem = 1; item.targetComponent = 1; item.seq = seqNo; item.frame = 6; item.command = 16;
    item.current = seqNo === 0 ? 1 : 0; item.autocontinue = 1;
    item.param1 = 0; item.param2 = ACCEPTANCE_RADIUS_M; item.param3 = 0; item.param4 = 0;
    item.x = Math.round(lat * 1e7); item.y = Math.round(lon * 1e7); item.z = -target[2];
    item.missionType = 0;
    return item;
  }
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
  if (qgc && qgcStep < qgcSteps.length) {
    phase = 'qgc';
    uploadSend(qgcRequest());
    return;
  }
  phase = 'upload';
  uploadSend(missionCount());
}
function commandLong(command, param1) {
  const c = new common.CommandLong();
  c.targetSystem = 1; c.targetComponent = 1; c.command = command; c.confirmation = 0;
  c._param1 = param1; c._param2 = 0; c._param3 = 0; c._param4 = 0; c._param5 = 0; c._param6 = 0; c._param7 = 0;
  return c;
}
function requestList() {
  const m = new common.MissionRequestList();
  m.targetSystem = 1; m.targetComponent = 1; m.missionType = 0;
  return m;
}
function clearAll() {
  const m = new common.MissionClearAll();
  m.targetSystem = 1; m.targetComponent = 1; m.missionType = 0;
  return m;
}
function requestItem(seqNo) {
  const m = new common.MissionRequestInt();
  m.targetSystem = 1; m.targetComponent = 1; m.seq = seqNo; m.missionType = 0;
  return m;
}
// The message of the current QGC step (retransmitted, like every request, until it is answered).
function qgcRequest() {
  switch (qgcSteps[qgcStep]) {
    case 'version': return commandLong(512, 148);  // MAV_CMD_REQUEST_MESSAGE AUTOPILOT_VERSION
    case 'home': return commandLong(512, 242);     // MAV_CMD_REQUEST_MESSAGE HOME_POSITION
    case 'params': { const m = new common.ParamRequestList(); m.targetSystem = 1; m.targetComponent = 1; return m; }
    default: return requestList();
  }
}
function nextQgcStep() {
  qgcStep += 1;
  downloadItems = []; downloadCount = null;
  startUpload();
}
// A download (MISSION_REQUEST_LIST → MISSION_COUNT → MISSION_REQUEST_INT each → MISSION_ITEM_INT each).
function onDownload(clazz, data, done) {
  if (clazz === common.MissionCount && data.missionType === 0 && downloadCount === null) {
    downloadCount = data.count;
    if (downloadCount === 0) return done([]);
    uploadSend(requestItem(0));
  } else if (clazz === common.MissionItemInt && downloadCount !== null && data.seq === downloadItems.length) {
    downloadItems.push({ seq: data.seq, frame: data.frame, x: data.x, y: data.y, z: data.z });
    if (downloadItems.length === downloadCount) {
      const ack = new common.MissionAck();
      ack.targetSystem = 1; ack.targetComponent = 1; ack.type = 0; ack.missionType = 0; ack.opaqueId = 0;
      send(ack);
      return done(downloadItems);
    }
    uploadSend(requestItem(downloadItems.length));
  }
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

const REGISTRY = { ...minimal.REGISTRY, ...standard.REGISTRY, ...common.REGISTRY };
packets.on('data', (packet) => {
  // The vehicle speaks only outside the secure execution interval, where the gate checks a frame's signature
  // instead of dropping it: a probe now reaches the check. (In lockstep at 10× real time an MC window lasts
  // tens of ms of wall-clock time: probes on a 100 ms clock alone can miss every window.)
  if (wrongKey && Date.now() - lastProbeAt >= 20) probe();
  report.vehicle_frames += 1;
  if (key && packet.signature && packet.signature.matches(key)) report.vehicle_frames_verified += 1;
  const clazz = REGISTRY[packet.header.msgid];
  if (!clazz) return;
  const data = packet.protocol.data(packet.payload, clazz);
  if (qgc) onQgc(clazz, data);
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

function onQgc(clazz, data) {
  if (clazz === common.CommandAck) {
    report.request_acks[data.command] = data.result;
    if (data.command === 20 && report.rtl_ack === null) {
      report.rtl_ack = data.result;
      if (phase === 'rtl') phase = 'returning';
    }
  }
  if (phase === 'qgc') {
    const step = qgcSteps[qgcStep];
    if (step === 'version' && clazz === standard.AutopilotVersion) {
      report.autopilot_version_capabilities = Number(data.capabilities);
      nextQgcStep();
    } else if (step === 'home' && clazz === common.HomePosition) {
      report.home = { lat: data.latitude / 1e7, lon: data.longitude / 1e7, alt_m: data.altitude / 1e3 };
      nextQgcStep();
    } else if (step === 'params' && clazz === common.ParamValue) {
      report.param_count = data.paramCount;
      const name = String(data.paramId).replace(/\0.*$/, '');
      report.param_types[name] = data.paramType;
      // MAV_PARAM_TYPE_INT32 (6): its four bytes in param_value (AUTOPILOT_VERSION says PARAM_ENCODE_BYTEWISE).
      if (data.paramType === 6) {
        const b = Buffer.alloc(4);
        b.writeFloatLE(data.paramValue);
        report.params[name] = b.readInt32LE();
      } else {
        report.params[name] = data.paramValue;
      }
      if (Object.keys(report.params).length === report.param_count) nextQgcStep();
    } else if (step === 'download_before') {
      onDownload(clazz, data, (items) => { report.download_before = items.length; nextQgcStep(); });
    }
    return;
  }
  if (clazz === common.MissionItemReached && report.upload_ack === MAV_MISSION_ACCEPTED) {
    report.item_reached.push(data.seq);
  }
  if (clazz === common.GlobalPositionInt && report.home) {
    const north = (data.lat / 1e7 - report.home.lat) * Math.PI / 180 * EARTH_RADIUS_M;
    const east = (data.lon / 1e7 - report.home.lon) * Math.PI / 180 * EARTH_RADIUS_M * Math.cos(report.home.lat * Math.PI / 180);
    const up = data.relativeAlt / 1e3;
    if (phase === 'watch') {
      const d = Math.hypot(north - target[0], east - target[1], up + target[2]);
      report.min_global_distance_m = Math.min(report.min_global_distance_m ?? d, d);
    }
    if (phase === 'returning') {
      // Home is the launch mission's first waypoint: over home at its altitude (3 m).
      const d = Math.hypot(north, east, up - 3);
      report.min_home_distance_after_rtl_m = Math.min(report.min_home_distance_after_rtl_m ?? d, d);
      if (d < ACCEPTANCE_RADIUS_M) { report.returned_home = true; phase = 'done_ok'; }
    }
  }
  // Once the waypoint is reached (ITEM_REACHED and within the radius): download what was uploaded, then RTL.
  if (phase === 'watch' && report.item_reached.includes(0) && report.min_global_distance_m !== null &&
      report.min_global_distance_m < ACCEPTANCE_RADIUS_M) {
    phase = 'download_after';
    uploadSend(requestList());
  } else if (phase === 'download_after') {
    onDownload(clazz, data, (items) => {
      report.download_after = items;
      downloadItems = []; downloadCount = null;
      phase = 'clear';
      uploadSend(clearAll());
    });
  } else if (phase === 'clear' && clazz === common.MissionAck && data.missionType === 0) {
    report.clear_ack = data.type;
    if (data.type !== MAV_MISSION_ACCEPTED) { phase = 'done'; return; }
    phase = 'download_after_clear';
    uploadSend(requestList());
  } else if (phase === 'download_after_clear') {
    onDownload(clazz, data, (items) => {
      report.download_after_clear = items;
      if (items.length === 1) {
        // Where the vehicle holds, against the waypoint it had reached (its setpoint was there).
        const north = (items[0].x / 1e7 - report.home.lat) * Math.PI / 180 * EARTH_RADIUS_M;
        const east = (items[0].y / 1e7 - report.home.lon) * Math.PI / 180 * EARTH_RADIUS_M *
                     Math.cos(report.home.lat * Math.PI / 180);
        report.hold_offset_m = Math.hypot(north - target[0], east - target[1], items[0].z + target[2]);
      }
      phase = 'rtl';
      uploadSend(commandLong(20, 0));
    });
  }
}

function complete() {
  if (qgc && !(report.clear_ack === MAV_MISSION_ACCEPTED && report.returned_home && report.rtl_ack === 0)) return false;
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

// Ended from outside (the run is over): the report as it stands, exit 0 only if every step was seen.
process.on('SIGTERM', () => finish(complete() ? 0 : 1));

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
    if (['upload', 'qgc', 'download_after', 'clear', 'download_after_clear', 'rtl'].includes(phase) && lastUpload && now - lastUploadAt >= retryMs) {
      uploadSend(lastUpload);
    }
    // With --wrong-key, all along (so that some arrive in MC, where the gate checks rather than drops): an
    // unsigned, a wrongly signed and a recorded MISSION_COUNT. The gate refuses them; ext_link never sees them.
    if (wrongKey && report.heartbeat && now % 100 < 20) probe();
  }, 20);
});
