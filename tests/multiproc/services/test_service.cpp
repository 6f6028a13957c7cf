// A purpose-built service for the multi-process tests (tests/multiproc): one binary, its behaviour chosen by
// the launch graph's text param `role`. Written against the SDK like a real service; the hostile roles also
// speak raw frames on fd 3, as an attacker that owns the process could.
//
// Topics (tests/multiproc/graphs/test.policy.pbtxt): numbers, echoes (SensorBaro layout used as a generic
// numbered record: pressure_pa = sequence number, altitude_m = value, temperature_c = sender tag), digest
// (sink's running hash of the order it saw everything in), security_event.
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "rejuv/channel/transport.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/sdk/testing.hpp"
#include "rejuv/sys/channel.hpp"

namespace {

using rejuv::sdk::LogLevel;
using rejuv::sdk::Service;
using Record = rejuv_msg_SensorBaro;

// splitmix64: deterministic values from the graph's seed.
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30U)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27U)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31U);
}

std::chrono::nanoseconds period(const Service& svc) {
  return std::chrono::microseconds(static_cast<std::int64_t>(svc.param("period_ms", 4) * 1000));
}

int fail(Service& svc, const std::string& what) {
  svc.log(LogLevel::Error, what);
  return 3;
}

// Publishes `burst` records every period; values from the seed.
int run_source(Service& svc) {
  auto out = svc.advertise<Record>("numbers");
  if (!out) return fail(svc, "advertise numbers: " + out.error().to_string());
  const auto burst = static_cast<int>(svc.param("burst", 1));
  const auto seed = static_cast<std::uint64_t>(svc.param("seed", 1));
  std::uint64_t n = 0;
  auto timer = svc.every(period(svc), [&] {
    for (int i = 0; i < burst; ++i) {
      Record r{};
      r.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
      r.pressure_pa = static_cast<double>(n);
      r.altitude_m = static_cast<double>(mix(seed ^ n) % 1000);
      r.temperature_c = 1;
      ++n;
      (void)out->publish(r);
    }
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

// Echoes every number (altitude transformed) and adds its own tick records.
int run_echo(Service& svc) {
  auto out = svc.advertise<Record>("echoes");
  if (!out) return fail(svc, "advertise echoes: " + out.error().to_string());
  std::uint64_t ticks = 0;
  auto in = svc.subscribe<Record>("numbers", [&](const Record& r) {
    Record e = r;
    e.altitude_m = r.altitude_m * 2 + 1;
    e.temperature_c = 2;
    (void)out->publish(e);
  });
  if (!in) return fail(svc, "subscribe numbers: " + in.error().to_string());
  auto timer = svc.every(period(svc) * 3, [&] {
    Record t{};
    t.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
    t.pressure_pa = static_cast<double>(ticks++);
    t.temperature_c = 3;
    (void)out->publish(t);
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

// Reads numbers through a polled subscription (deliveries never wake it) on a timer of 20 periods, and reports on
// echoes what it found: pressure_pa = the newest number it holds, altitude_m = deliveries received so far,
// temperature_c = 4.
int run_poller(Service& svc) {
  auto out = svc.advertise<Record>("echoes");
  if (!out) return fail(svc, "advertise echoes: " + out.error().to_string());
  auto in = svc.subscribe_polled<Record>("numbers");
  if (!in) return fail(svc, "subscribe numbers: " + in.error().to_string());
  auto timer = svc.every(period(svc) * 20, [&] {
    Record r{};
    r.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
    r.pressure_pa = in->valid() ? in->copy().pressure_pa : -1;
    r.altitude_m = static_cast<double>(in->received());
    r.temperature_c = 4;
    (void)out->publish(r);
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

// Hashes the order in which it sees numbers, echoes and security events; publishes the digest every period.
int run_sink(Service& svc) {
  auto out = svc.advertise<Record>("digest");
  if (!out) return fail(svc, "advertise digest: " + out.error().to_string());
  std::uint64_t hash = 1469598103934665603ULL;
  std::uint64_t seen = 0;
  const auto fold = [&](double a, double b, double c) {
    for (const double v : {a, b, c}) {
      std::uint64_t bits = 0;
      std::memcpy(&bits, &v, sizeof(bits));
      hash = (hash ^ bits) * 1099511628211ULL;
    }
    ++seen;
  };
  auto numbers = svc.subscribe<Record>("numbers", [&](const Record& r) { fold(r.pressure_pa, r.altitude_m, 10); });
  if (!numbers) return fail(svc, "subscribe numbers: " + numbers.error().to_string());
  auto echoes = svc.subscribe<Record>("echoes", [&](const Record& r) { fold(r.pressure_pa, r.altitude_m, r.temperature_c); });
  if (!echoes) return fail(svc, "subscribe echoes: " + echoes.error().to_string());
  auto events = svc.subscribe<rejuv_msg_SecurityEvent>("security_event", [&](const rejuv_msg_SecurityEvent& e) {
    fold(e.service_id, e.slot, 100 + e.error);
  });
  if (!events) return fail(svc, "subscribe security_event: " + events.error().to_string());
  auto timer = svc.every(period(svc), [&] {
    Record d{};
    d.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
    d.pressure_pa = static_cast<double>(seen);
    d.altitude_m = static_cast<double>(hash >> 12U);  // exact in a double
    d.temperature_c = static_cast<double>(numbers->lost() + echoes->lost());
    (void)out->publish(d);
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

// Subscribes to numbers and, after `stall_after` deliveries, stops reading its channel for good.
int run_stall(Service& svc) {
  const auto after = static_cast<std::uint64_t>(svc.param("stall_after", 0));
  std::uint64_t got = 0;
  auto in = svc.subscribe<Record>("numbers", [&](const Record&) {
    if (++got >= after) {
      for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
    }
  });
  if (!in) return fail(svc, "subscribe numbers: " + in.error().to_string());
  return svc.run();
}

// Hostile: on every tick, from `start_ms` on, does what param `attack` says.
//   forge:   publishes on numbers (held with Read only) and on forged/empty slots — all denied.
//   garbage: sends malformed frames of every kind of wrongness, plus a frame carrying an fd.
//   packed:  sends one datagram of three frames (wire::next_frame): a Publish on the Read-only slot (denied),
//            a garbage header (refused), and the same Publish again (never read: past a bad frame the
//            kernel drops the rest of the datagram).
//   crash:   aborts (a service killed mid-run).
//   none:    only reads numbers.
int run_intruder(Service& svc) {
  const std::string attack(svc.text_param("attack", "none"));
  const auto start = std::chrono::microseconds(static_cast<std::int64_t>(svc.param("start_ms", 0) * 1000));
  auto in = svc.subscribe<Record>("numbers");
  if (!in) return fail(svc, "subscribe numbers: " + in.error().to_string());
  auto numbers = svc.cap("numbers");
  if (!numbers) return fail(svc, "cap numbers: " + numbers.error().to_string());
  const rejuv::Slot read_only_slot = (*numbers)->slot;
  rejuv::wire::FrameBuffer fb;
  auto timer = svc.every(period(svc), [&] {
    if (svc.now() < start) return;
    if (attack == "forge") {
      const Record r{};
      const auto bytes = std::as_bytes(std::span(&r, 1));
      for (const std::uint32_t slot : {read_only_slot.value(), 0U, 77U, 255U, 100000U}) {
        if (fb.build(rejuv::wire::FrameKind::Publish, slot, 0, 0, bytes)) (void)rejuv::sdk::testing::send_raw(svc, fb.bytes());
      }
    } else if (attack == "garbage") {
      std::array<std::byte, 64> junk{};
      for (std::size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<std::byte>(i * 37 + 11);
      (void)rejuv::sdk::testing::send_raw(svc, std::span(junk).first(5));              // shorter than a header
      (void)rejuv::sdk::testing::send_raw(svc, junk);                                  // garbage header
      rejuv::wire::FrameHeader h{};
      h.kind = 999;                                              // unknown kind
      (void)rejuv::sdk::testing::send_raw(svc, std::as_bytes(std::span(&h, 1)));
      h.kind = static_cast<std::uint16_t>(rejuv::wire::FrameKind::Deliver);  // wrong direction
      (void)rejuv::sdk::testing::send_raw(svc, std::as_bytes(std::span(&h, 1)));
      h.kind = static_cast<std::uint16_t>(rejuv::wire::FrameKind::Idle);
      h.flags = 1;                                               // reserved flags
      (void)rejuv::sdk::testing::send_raw(svc, std::as_bytes(std::span(&h, 1)));
      h.flags = 0;
      h.length = 1000;                                           // length disagrees with the datagram
      (void)rejuv::sdk::testing::send_raw(svc, std::as_bytes(std::span(&h, 1)));
      const std::array<std::byte, 3> tiny{};
      if (fb.build(rejuv::wire::FrameKind::Publish, read_only_slot.value(), 0, 0, tiny)) {
        (void)rejuv::sdk::testing::send_raw(svc, fb.bytes());                          // wrong payload size (and no Write right)
      }
      if (fb.build(rejuv::wire::FrameKind::TimerArm, 0, 0, 0, tiny)) (void)rejuv::sdk::testing::send_raw(svc, fb.bytes());  // bad size
      if (fb.build(rejuv::wire::FrameKind::Taken, 0, 0, 0, std::as_bytes(std::span(&h, 1)).first(8))) {
        (void)rejuv::sdk::testing::send_raw(svc, fb.bytes());                          // Taken without a Snapshot
      }
      // A frame that carries an fd (a copy of the time page fd): the kernel must close it and refuse.
      rejuv::sys::SeqPacket raw{rejuv::sys::UniqueFd(rejuv::wire::kChannelFd)};
      if (fb.build(rejuv::wire::FrameKind::Idle, 0, 0, 0)) {
        const std::array<int, 1> fds{rejuv::wire::kTimePageFd};
        (void)raw.send(fb.bytes(), fds);
      }
      (void)raw.take_fd().release();  // fd 3 still belongs to the SDK
    } else if (attack == "packed") {
      const Record r{};
      std::vector<std::byte> datagram;
      const auto append = [&](std::span<const std::byte> frame) { rejuv::channel::append_frame(datagram, frame); };
      if (!fb.build(rejuv::wire::FrameKind::Publish, read_only_slot.value(), 0, 0, std::as_bytes(std::span(&r, 1)))) return;
      append(fb.bytes());
      rejuv::wire::FrameHeader junk{};
      junk.kind = 999;
      append(std::as_bytes(std::span(&junk, 1)));
      append(fb.bytes());
      (void)rejuv::sdk::testing::send_raw(svc, datagram);
    } else if (attack == "crash") {
      std::abort();
    }
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

}  // namespace

int main() {
  auto svc = Service::connect();
  if (!svc) return rejuv::sdk::report_connect_failure(svc.error());
  Service& s = **svc;
  const std::string role(s.text_param("role", ""));
  if (role == "source") return run_source(s);
  if (role == "echo") return run_echo(s);
  if (role == "poller") return run_poller(s);
  if (role == "sink") return run_sink(s);
  if (role == "stall") return run_stall(s);
  if (role == "intruder") return run_intruder(s);
  if (role == "idle") return s.run();
  if (role == "hang") {
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));  // never Ready: the boot deadline
  }
  return fail(s, "unknown role '" + role + "'");
}
