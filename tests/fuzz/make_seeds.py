#!/usr/bin/env python3
"""Writes the generated seed corpora of tests/fuzz (channel_frames, sdk_frames, plant_samples)
from real frames: the layouts of kernel_sim/channel wire.hpp and idl/.
The policy_loader and launch_loader seeds are the repository's policies/ and launch/ files, copied.
Run from anywhere: python3 tests/fuzz/make_seeds.py (rewrites corpus/<target>/seed_*)."""
import pathlib
import shutil
import struct

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent

# wire.hpp FrameKind
HELLO, PUBLISH, SUBSCRIBE, INVOKE, TIMER_ARM, TIMER_CANCEL, LOG, IDLE, READY, TAKEN, RESUMED, COPIED, TAKEN_PAGES = range(1, 14)
BOOT, BOOT_CAP, BOOT_PARAM, BOOT_END = 100, 101, 102, 103
DELIVER, REPLY, TIMER_FIRED, SNAPSHOT, SHUTDOWN, RESUME, NET_DATAGRAM = 110, 111, 112, 113, 115, 116, 117
# cap::Operation
OP = dict(CheckpointCreate=2, CheckpointRollback=3, TimerArm=4, NetSend=5, NetReceive=6, LimitsWrite=7,
          LimitsRead=8, PersistentRead=9, PersistentWrite=10, ModeRequest=11, Copy=12, Mint=13, Revoke=14,
          Delete=15)


def frame(kind, slot=0, seq=0, aux=0, payload=b""):
    return struct.pack("<HHIIIQ", kind, 0, slot, seq, len(payload), aux) + payload


def pack(*frames):  # one datagram of several frames, each at a multiple of 8 (wire::next_frame)
    out = b""
    for f in frames:
        out += f + b"\0" * (-len(f) % 8)
    return out[: len(out) - (-len(frames[-1]) % 8)]  # no padding after the last frame


def baro(t=1, p=101325.0, alt=3.0, temp=15.0):
    return struct.pack("<Qddd", t, p, alt, temp)  # idl/sensors.idl SensorBaro (32 bytes)


def invoke(slot, seq, op, arg0=0, arg1=0, data=b""):
    return frame(INVOKE, slot, seq, 0, struct.pack("<B7xQQ", op, arg0, arg1) + data)


def record(datagram):
    return struct.pack("<H", len(datagram)) + datagram


def write(target, name, data):
    d = HERE / "corpus" / target
    d.mkdir(parents=True, exist_ok=True)
    (d / ("seed_" + name)).write_bytes(data)


# ---- channel_frames: u8 flags, then ops (0xFF: step; else service index + record) ----
SOURCE, ECHO, SINK, STALL, INTRUDER = range(5)
STEP = b"\xff"


def ops(flags, *items):
    out = bytes([flags])
    for it in items:
        out += STEP if it == "step" else bytes([it[0]]) + record(it[1])
    return out


write("channel_frames", "publish_route", ops(1, (ECHO, frame(SUBSCRIBE, 1, 1)), (SINK, frame(SUBSCRIBE, 1, 1, 1)),
                                             (SOURCE, frame(PUBLISH, 1, 0, 0, baro())), "step",
                                             (ECHO, frame(PUBLISH, 2, 0, 0, baro(2))), "step"))
write("channel_frames", "packed", ops(1, (SINK, pack(frame(SUBSCRIBE, 1, 1), frame(SUBSCRIBE, 2, 2), frame(SUBSCRIBE, 4, 3))),
                                      (SOURCE, pack(*[frame(PUBLISH, 1, 0, 0, baro(i)) for i in range(12)])), "step", "step"))
write("channel_frames", "denied", ops(1, (SINK, frame(SUBSCRIBE, 4, 1)), (INTRUDER, frame(PUBLISH, 1, 0, 0, baro())),
                                      (INTRUDER, frame(SUBSCRIBE, 9, 2)), "step", (SINK, frame(PUBLISH, 1, 0, 0, baro())), "step"))
write("channel_frames", "invoke", ops(1, (SINK, pack(invoke(1, 1, OP["Copy"], 7, 1), invoke(1, 2, OP["Mint"], 8, 0x501),
                                                     invoke(7, 3, OP["Revoke"]), invoke(8, 4, OP["Delete"]),
                                                     invoke(1, 5, OP["PersistentRead"], 0, 8),
                                                     invoke(1, 6, OP["ModeRequest"], 1), invoke(1, 7, OP["TimerArm"], 1000),
                                                     invoke(1, 8, OP["CheckpointCreate"]), invoke(3, 9, 200),
                                                     invoke(1, 10, OP["Copy"], (1 << 63) | 4, 1))), "step"))
write("channel_frames", "timers", ops(1, (STALL, frame(TIMER_ARM, 0, 0, 0, struct.pack("<QQQ", 7, 1_000_000, 1_000_000))),
                                      (ECHO, frame(TIMER_ARM, 0, 0, 0, struct.pack("<QQQ", 1, 2_000_000, 0))),
                                      "step", "step", "step", (STALL, frame(TIMER_CANCEL, 0, 0, 7)), "step"))
write("channel_frames", "log_idle", ops(1, (SOURCE, frame(LOG, 0, 0, 0, struct.pack("<B7x", 2) + b"hello \x1b[31m kernel")),
                                        (SOURCE, frame(IDLE, 0, 0, 3)), "step"))
write("channel_frames", "boot_by_hand", ops(0, (SOURCE, frame(PUBLISH, 1, 0, 0, baro())), (SOURCE, frame(HELLO, 0, 0, 1)),
                                            (SOURCE, frame(READY)), (SOURCE, frame(HELLO, 0, 0, 1)),
                                            (SOURCE, frame(PUBLISH, 1, 0, 0, baro())), "step"))
write("channel_frames", "image_frames", ops(1, (ECHO, frame(TAKEN, 0, 0, 1, struct.pack("<iI", 1, 0))),
                                            (ECHO, frame(TAKEN_PAGES, 0, 0, 1, struct.pack("<QQ", 0, 1))),
                                            (ECHO, frame(RESUMED, 0, 0, 1, struct.pack("<iI", 1, 0))), "step"))
write("channel_frames", "wrong_size", ops(1, (SOURCE, frame(PUBLISH, 1, 0, 0, b"\x01" * 8)),
                                          (SOURCE, frame(PUBLISH, 1, 0, 0, baro())[:-4]), (SOURCE, b""), "step"))

# ---- sdk_frames: records, each one datagram queued for the service ----
def boot_script(caps, params):
    fs = [frame(BOOT, 0, 0, 1, struct.pack("<IIIIQ48s", 3, 0, len(caps), len(params), 0, b"probe"))]
    for slot, kind, obj, typ, size, rights in caps:
        fs.append(frame(BOOT_CAP, 0, 0, 0, struct.pack("<IB5B2xII48s64s", slot, kind, *rights, size, 0, obj, typ)))
    for name, number, text in params:
        fs.append(frame(BOOT_PARAM, 0, 0, 0, struct.pack("<dB7x48s128s", number, 1 if text else 0, name, text or b"")))
    fs.append(frame(BOOT_END))
    return fs


R, W = 1, 2
TOPIC, PERSISTENT, NETWORK = 0, None, None
CAPS = [(1, 0, b"numbers", b"rejuv::msg::SensorBaro", 32, [R] * 5),
        (2, 0, b"out", b"rejuv::msg::SensorBaro", 32, [W, 0, 0, 0, 0])]
PARAMS = [(b"gain", 2.5, None), (b"clock", 0, b"lockstep")]


def sdk(*datagrams):
    return b"".join(record(d) for d in datagrams)


boot = boot_script(CAPS, PARAMS)
reply_ok = lambda seq, data=b"": frame(REPLY, 0, seq, 0, struct.pack("<iIQ", 0, 0, 0) + data)
write("sdk_frames", "boot_only", sdk(*boot))
write("sdk_frames", "boot_packed", sdk(pack(*boot)))
write("sdk_frames", "deliver", sdk(*boot, reply_ok(1), reply_ok(2), frame(DELIVER, 1, 0, 1, baro()),
                                   frame(DELIVER, 1, 0, 3, baro(2)), frame(TIMER_FIRED, 0, 0, 1), frame(SHUTDOWN)))
write("sdk_frames", "bad_frames", sdk(*boot, frame(DELIVER, 1, 0, 1, baro()), reply_ok(1), reply_ok(7),
                                      frame(DELIVER, 9, 0, 1, baro()), frame(SNAPSHOT, 0, 0, 1, struct.pack("<Q", 0)),
                                      frame(NET_DATAGRAM, 5, 0, 1, b"RJLK"), frame(BOOT_END)))

# ---- mavlink_frames: one MAVLink 2 frame per seed, made by node-mavlink (tests/mavlink_client/make_vectors.js,
# the known-answer frames of tests/unit/mavlink), not here: an independent encoder is the better seed ----

# ---- plant_samples: u64 seed, then records: u8 kind (even: ActuatorOutputs, odd: SimStepAck) + struct ----
def outputs(m, restricted=0):  # idl/control.idl ActuatorOutputs: u64, double[4], u8 (+7 padding)
    return struct.pack("<Q4dB7x", 1, *m, restricted)


def ack(step, charged, outs):
    body = struct.pack("<QQQQB7x", step, step * 4_000_000, charged, 0, len(outs))
    for o in (outs + [(0, 0, 0, 0)] * 2)[:2]:
        body += outputs(o)
    return body


hover = (0.5, 0.5, 0.5, 0.5)
write("plant_samples", "hover", struct.pack("<Q", 1) + b"\x00" + outputs(hover) +
      b"".join(b"\x01" + ack(k, 0, [hover]) for k in range(8)))
write("plant_samples", "charged", struct.pack("<Q", 2) + b"\x01" + ack(0, 20_000_000, [(1, 1, 1, 1), (0, 0, 0, 0)]) +
      b"\x01" + ack(1, 0, []))
write("plant_samples", "nan", struct.pack("<Q", 3) + b"\x00" + outputs((float("nan"), 0.5, 0.5, 0.5)) +
      b"\x01" + ack(0, 0, [(float("inf"), 0, 0, 0)]))

# ---- policy_loader / launch_loader: the repository's files ----
for target, src, pattern in (("policy_loader", ROOT / "policies", "**/*.policy.pbtxt"),
                             ("policy_loader", ROOT / "tests/multiproc/graphs", "*.policy.pbtxt"),
                             ("launch_loader", ROOT / "launch", "*.launch.pbtxt")):
    for f in sorted(src.glob(pattern)):
        d = HERE / "corpus" / target
        d.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(f, d / ("seed_" + f.name))
