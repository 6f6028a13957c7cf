// The security tests' service (tests/security/attack_test.cpp; graphs/attacks.policy.pbtxt): one binary,
// its role chosen by the text param `role`, and in every role the runtime attack hooks of the launch plan
// (services/attacks) — the test's launch text names which service is compromised with which attack.
//
// What it reports on `verdicts` is one record type per kind of report (verdicts.hpp: LimitsRead, CellRead,
// CheckpointTaken, AttackAttempt, EscapeReport), encoded there.
//
//   rejuv   the SR cycle in miniature (checkpoint_p): in the secure interval, after `sei_ticks` ticks, reads
//   and
//           writes the cell, writes the restricted limits, checkpoints; on Taken arms the rejuvenation timer
//           for `t_mc_ms` and requests MC; a restored image starts the secure interval again.
//   worker  publishes one number per tick on `numbers`. With the text param `escape` (hostile_test.cpp) it is
//           compromised: it tries that escape once at `escape_at` = "boot" (after connect, before Ready: boot
//           calls such as open still pass) or "mc" (its first tick in each MC window), against the targets in
//           the params udp_port, path, victim, address, fd, hog_mb.
//   link    holds the network (MC); sends nothing itself.
//   driver  every tick reads the limits and publishes actuator_outputs (the only writer).
#include <array>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include <unistd.h>

#include "escapes.hpp"
#include "rejuv/attacks/hooks.hpp"
#include "rejuv/sdk/attack_hook.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/sdk/testing.hpp"
#include "services/test_records.hpp"
#include "verdicts.hpp"

namespace {

using rejuv::sdk::CheckpointOutcome;
using rejuv::sdk::LogLevel;
using rejuv::sdk::Service;
using rejuv::test_services::fail;
using rejuv::test_services::Record;
using rejuv::test_services::record;
using Op = rejuv::cap::Operation;

namespace v = rejuv::test_services::verdicts;

std::uint64_t stamp(const Service& svc) {
  return static_cast<std::uint64_t>(svc.now().count());
}

constexpr double kRestrictedLimit = 0.3;  // what rejuv writes: the legitimate Ū
constexpr auto kTick = std::chrono::milliseconds(4);

int run_rejuv(Service& svc, const rejuv::sdk::Publisher<Record>& verdicts) {
  const auto sei_ticks = static_cast<int>(svc.param("sei_ticks", 3));
  const auto t_mc = std::chrono::milliseconds(static_cast<std::int64_t>(svc.param("t_mc_ms", 40)));
  int ticks = 0;
  std::uint64_t cycles = 0;
  auto timer = svc.every(kTick, [&] {
    if (svc.mode() == rejuv::SrMode::MC || ++ticks != sei_ticks) return;
    std::uint64_t cell = 0;
    if (auto r = rejuv::sdk::testing::invoke(svc, "cell", Op::PersistentRead, 0, 8, {}, std::as_writable_bytes(std::span(&cell, 1))); r) {
      (void)verdicts.publish(v::encode(v::CellRead{.cell = static_cast<double>(cell)}, stamp(svc)));
    }
    cycles = cell + 1;
    (void)rejuv::sdk::testing::invoke(svc, "cell", Op::PersistentWrite, 0, 0, std::as_bytes(std::span(&cycles, 1)));
    std::array<double, 16> limits{};
    limits.fill(kRestrictedLimit);
    (void)rejuv::sdk::testing::invoke(svc, "limits", Op::LimitsWrite, 0, 0, std::as_bytes(std::span(limits)));
    auto taken = svc.checkpoint();
    if (!taken) {
      svc.logf(LogLevel::Error, "checkpoint: %s", taken.error().to_string().c_str());
      return;
    }
    if (taken->kind == CheckpointOutcome::Kind::Restored) {
      ticks = 0;  // a new secure interval (RB): checkpoint again after sei_ticks
      return;
    }
    (void)verdicts.publish(v::encode(
        v::CheckpointTaken{.generation = static_cast<double>(taken->generation.value())}, stamp(svc)));
    if (auto a = rejuv::sdk::testing::invoke(svc, "checkpoint", Op::TimerArm, static_cast<std::uint64_t>(std::chrono::nanoseconds(t_mc).count())); !a) {
      svc.logf(LogLevel::Error, "arm: %s", a.error().to_string().c_str());
    }
    (void)rejuv::sdk::testing::invoke(svc, "mode", Op::ModeRequest, rejuv::index_of(rejuv::SrMode::MC));
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

namespace escapes = rejuv::test_services::escapes;

escapes::Target escape_target(const Service& svc) {
  return escapes::Target{.udp_port = static_cast<std::uint16_t>(svc.param("udp_port", 0)),
                         .path = std::string(svc.text_param("path", "")),
                         .victim = static_cast<pid_t>(svc.param("victim", -1)),
                         .address = static_cast<std::uint64_t>(svc.param("address", 0)),
                         .fd = static_cast<int>(svc.param("fd", 0)),
                         .hog_mb = static_cast<std::uint32_t>(svc.param("hog_mb", 0))};
}

int run_worker(Service& svc, const rejuv::sdk::Publisher<Record>& verdicts) {
  auto out = svc.advertise<Record>("numbers");
  if (!out) return fail(svc, "advertise numbers: " + out.error().to_string());
  const std::string escape(svc.text_param("escape", ""));
  const bool at_boot = svc.text_param("escape_at", "mc") == "boot";
  escapes::Target target = escape_target(svc);
  target.first_pid = ::getpid();
  target.numbers_slot = out->slot().value();
  target.numbers_size = sizeof(Record);  // at boot: the first incarnation (its images inherit the value)
  std::optional<escapes::Outcome> outcome;  // of the escape at boot, reported at the first tick
  if (!escape.empty() && at_boot) {
    outcome = escapes::perform(escape, target);
    if (!outcome) return fail(svc, "unknown escape '" + escape + "'");
  }
  bool tried_in_mc = false;  // in this MC window (a restored image starts again from its checkpoint)
  double n = 0;
  auto timer = svc.every(kTick, [&] {
    (void)out->publish(record(svc, 0, ++n, 0));
    if (!escape.empty() && !at_boot && !tried_in_mc && svc.mode() == rejuv::SrMode::MC) {
      tried_in_mc = true;
      (void)svc.flush();  // what it published so far is out before the attempt
      target.epoch = svc.epoch().value();
      outcome = escapes::perform(escape, target);
      if (!outcome) svc.stop(fail(svc, "unknown escape '" + escape + "'"));
    }
    if (outcome) {
      (void)verdicts.publish(
          v::encode(v::EscapeReport{.value = outcome->value, .detail = outcome->detail}, stamp(svc)));
      outcome.reset();
    }
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

int run_driver(Service& svc, const rejuv::sdk::Publisher<Record>& verdicts) {
  auto outputs = svc.advertise<rejuv_msg_ActuatorOutputs>("actuator_outputs");
  if (!outputs) return fail(svc, "advertise actuator_outputs: " + outputs.error().to_string());
  auto numbers = svc.subscribe<Record>("numbers");
  if (!numbers) return fail(svc, "subscribe numbers: " + numbers.error().to_string());
  auto timer = svc.every(kTick, [&] {
    std::array<double, 16> limits{};
    if (auto r = rejuv::sdk::testing::invoke(svc, "limits", Op::LimitsRead, 0, 0, {}, std::as_writable_bytes(std::span(limits))); r && r->data_size > 0) {
      (void)verdicts.publish(v::encode(
          v::LimitsRead{.first_limit = limits[0], .bytes = static_cast<double>(r->data_size)}, stamp(svc)));
    }
    rejuv_msg_ActuatorOutputs u{};
    u.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
    for (double& m : u.motor) m = 0.5;
    (void)outputs->publish(u);
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

}  // namespace

int main() {
  auto connected = Service::connect();
  if (!connected) return rejuv::sdk::report_connect_failure(connected.error());
  Service& s = **connected;
  const std::string role(s.text_param("role", ""));
  auto verdicts = s.advertise<Record>("verdicts");
  if (!verdicts) return fail(s, "advertise verdicts: " + verdicts.error().to_string());
  // ==== ATTACK HOOKS ====: whatever the launch plan names for this service; every attempt is reported.
  auto hooks = rejuv::attacks::install(s);
  if (!s.require(hooks, "bad attack params")) return 1;
  if (*hooks) {
    (*hooks)->on_attempt([&](const rejuv::attacks::Attempt& a) {
      (void)verdicts->publish(v::encode(
          static_cast<double>(a.kind),
          v::AttackAttempt{.code = static_cast<double>(a.code), .target = static_cast<double>(a.target)},
          stamp(s)));
    });
  }
  // ==== CUSTOM HOOK ====: the SDK's (rejuv/sdk/attack_hook.hpp), as a service author installs it: each
  // window that begins is reported, and each tick at which the hook says a window is in force.
  auto custom = rejuv::sdk::on_attack(s, [&](const rejuv::sdk::AttackWindow& w) {
    (void)verdicts->publish(v::encode(
        v::CustomWindow{.mode = static_cast<double>(rejuv::index_of(s.mode())), .magnitude = w.magnitude},
        stamp(s)));
  });
  if (!s.require(custom, "bad CUSTOM attack params")) return 1;
  if (*custom) {
    auto watch = s.every(kTick, [&] {
      if (const auto w = (*custom)->window()) {
        (void)verdicts->publish(
            v::encode(v::CustomActive{.epoch = static_cast<double>(w->epoch.value()),
                                      .mode = static_cast<double>(rejuv::index_of(s.mode()))},
                      stamp(s)));
      }
    });
    if (!s.require(watch, "timer")) return 1;
  }
  if (role == "rejuv") return run_rejuv(s, *verdicts);
  if (role == "worker") return run_worker(s, *verdicts);
  if (role == "driver") return run_driver(s, *verdicts);
  if (role == "link") return s.run();
  return fail(s, "unknown role '" + role + "'");
}
