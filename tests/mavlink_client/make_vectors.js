// Known-answer vectors for the MAVLink codec's unit tests (tests/unit/mavlink/mavlink_test.cpp), made by an
// implementation Rejuv did not write: node-mavlink. Run from a folder where `npm ci` installed this package:
//   node tests/mavlink_client/make_vectors.js > vectors.txt   (prints one "name hex" line per frame)
'use strict';
const { MavLinkProtocolV2, minimal, common } = require('node-mavlink');

const key = Buffer.from('00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff', 'hex');
const frames = [];
function add(name, msg, seq, sysid = 1, compid = 1, sign = null) {
  const p = new MavLinkProtocolV2(sysid, compid, sign ? MavLinkProtocolV2.IFLAG_SIGNED : 0);
  let b = p.serialize(msg, seq);
  // timestamp is in ms for node-mavlink's sign(); it stores (ms - 2015-01-01) * 100 [10 µs].
  if (sign) b = p.sign(b, sign.link, key, sign.ms);
  frames.push(`${name} ${b.toString('hex')}`);
}

const hb = new minimal.Heartbeat();
hb.type = 2; hb.autopilot = 0; hb.baseMode = 129; hb.customMode = 0x00010002; hb.systemStatus = 4; hb.mavlinkVersion = 3;
add('heartbeat', hb, 7);

const lp = new common.LocalPositionNed();
lp.timeBootMs = 123456; lp.x = 1.5; lp.y = -2.25; lp.z = -3; lp.vx = 0.125; lp.vy = 0; lp.vz = 0;
add('local_position_ned', lp, 8);

const att = new common.Attitude();
att.timeBootMs = 1000; att.roll = 0.1; att.pitch = -0.2; att.yaw = 1.5; att.rollspeed = 0; att.pitchspeed = 0; att.yawspeed = 0.01;
add('attitude', att, 9);

const st = new common.StatusText();
st.severity = 4; st.text = 'rollback 3: restored in 1.2 ms'; st.id = 0; st.chunkSeq = 0;
add('statustext', st, 10);

const mc = new common.MissionCount();
mc.targetSystem = 1; mc.targetComponent = 1; mc.count = 3; mc.missionType = 0; mc.opaqueId = 0;
add('mission_count', mc, 11, 255, 190);

const item = new common.MissionItemInt();
item.targetSystem = 1; item.targetComponent = 1; item.seq = 2; item.frame = 1; item.command = 16; item.current = 0;
item.autocontinue = 1; item.param1 = 0; item.param2 = 0.5; item.param3 = 0; item.param4 = 1.25;
item.x = 10000; item.y = -5000; item.z = -3; item.missionType = 0;
add('mission_item_int', item, 12, 255, 190);

const ack = new common.MissionAck();
ack.targetSystem = 255; ack.targetComponent = 190; ack.type = 13; ack.missionType = 0; ack.opaqueId = 0;
add('mission_ack', ack, 13);

const req = new common.MissionRequestInt();
req.targetSystem = 255; req.targetComponent = 190; req.seq = 1; req.missionType = 0;
add('mission_request_int', req, 14);

const gp = new common.GlobalPositionInt();
gp.timeBootMs = 5; gp.lat = 473977420; gp.lon = 85455940; gp.alt = 488000; gp.relativeAlt = 3000; gp.vx = -12; gp.vy = 3; gp.vz = 0; gp.hdg = 9000;
add('global_position_int', gp, 15);

const sys = new common.SysStatus();
sys.onboardControlSensorsPresent = 0x20; sys.onboardControlSensorsEnabled = 0x20; sys.onboardControlSensorsHealth = 0x20;
sys.load = 500; sys.voltageBattery = 12600; sys.currentBattery = -1; sys.dropRateComm = 0; sys.errorsComm = 0;
sys.errorsCount1 = 0; sys.errorsCount2 = 0; sys.errorsCount3 = 0; sys.errorsCount4 = 0; sys.batteryRemaining = -1;
sys.onboardControlSensorsPresentExtended = 0; sys.onboardControlSensorsEnabledExtended = 0; sys.onboardControlSensorsHealthExtended = 0;
add('sys_status', sys, 16);

const reached = new common.MissionItemReached();
reached.seq = 0;  // an all-zero payload: node-mavlink sends 0 payload bytes (the spec keeps 1); both decode
add('mission_item_reached_zero', reached, 17);

// Signed: the same MISSION_COUNT with link id 3 at 2026-01-01 00:00:00.010 UTC.
add('mission_count_signed', mc, 18, 255, 190, { link: 3, ms: Date.UTC(2026, 0, 1, 0, 0, 0, 10) });

const list = new common.MissionRequestList();
list.targetSystem = 1; list.targetComponent = 1; list.missionType = 0;
add('mission_request_list', list, 19, 255, 190);

for (const f of frames) console.log(f);
