// The test service of the image-store tests (tests/multiproc/image_multiproc_test.cpp, docs/design.md §7): one
// binary, its behaviour chosen by the text param `role`. Graph: tests/multiproc/graphs/images.policy.pbtxt.
//
// Records are SensorBaro used as a generic numbered record: pressure_pa = sequence number, altitude_m =
// a value, temperature_c = a tag.
//   counter  — every period publishes `burst` numbers (a running sequence); checkpoints at step
//              `checkpoint_at` and, once restored, at once again (like checkpoint_p); rolls back at step
//              `rollback_at` (param rollback_by: "invoke" = CheckpointRollback, "timer" = arms the
//              rejuvenation timer for one period after each Taken) until the persistent cell `cycles`
//              reaches `max_cycles`. altitude_m = cycles, temperature_c = the step count.
//              With `arm_twice` set, arms the timer twice after each Taken (the second must be refused) and
//              publishes the refusal on `verdicts`.
//   listener — echoes every number it receives: pressure_pa = the number, altitude_m = how many numbers it
//              has received (in its own history), temperature_c = the epoch.
//   driver   — like the listener (rejuvenate: false in the graph: never rolled back).
//   worker   — runs one registered worker thread; every period publishes on `verdicts` how many threads
//              besides the main one run in this process (altitude_m) and the worker's incarnation
//              (temperature_c).
//   hooked   — registers on_restored, which publishes on `verdicts` pressure_pa = kRestoredMark, altitude_m =
//              the epoch it was given, temperature_c = epoch() as the time page shows it then; every period
//              publishes pressure_pa = 0, altitude_m = epoch() (a handler of that epoch).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>

#include "rejuv/sdk/service.hpp"
#include "test_records.hpp"

namespace {

using rejuv::sdk::CheckpointOutcome;
using rejuv::sdk::LogLevel;
using rejuv::sdk::Service;
using rejuv::test_services::fail;
using rejuv::test_services::Record;
using rejuv::test_services::record;

std::chrono::nanoseconds period(const Service& svc) {
  return std::chrono::microseconds(static_cast<std::int64_t>(svc.param("period_ms", 4) * 1000));
}

int run_counter(Service& svc) {
  auto out = svc.advertise<Record>("numbers");
  auto verdicts = svc.advertise<Record>("verdicts");
  if (!out || !verdicts) return fail(svc, "advertise");
  const auto burst = static_cast<int>(svc.param("burst", 1));
  const auto checkpoint_at = static_cast<std::uint64_t>(svc.param("checkpoint_at", 5));
  const auto rollback_at = static_cast<std::uint64_t>(svc.param("rollback_at", 10));
  const auto max_cycles = static_cast<std::uint64_t>(svc.param("max_cycles", 1));
  const bool by_timer = svc.text_param("rollback_by", "invoke") == "timer";
  const bool arm_twice = svc.param("arm_twice", 0) != 0;
  std::uint64_t step = 0;
  std::uint64_t sequence = 0;
  std::uint64_t cycles = 0;  // the persistent cell's value, as last read or written
  const auto read_cycles = [&]() -> std::uint64_t {
    std::uint64_t v = 0;
    auto cell = svc.persistent("cycles");
    auto r = cell ? cell->read(std::as_writable_bytes(std::span(&v, 1))) : std::unexpected(cell.error());
    return r ? v : 0;
  };
  const auto arm = [&]() {
    auto rejuvenation = svc.rejuvenation();
    if (!rejuvenation) return svc.logf(LogLevel::Warn, "arm: %s", rejuvenation.error().to_string().c_str());
    auto first = rejuvenation->arm_timer(period(svc));
    if (!first) svc.logf(LogLevel::Warn, "arm: %s", first.error().to_string().c_str());
    if (arm_twice) {
      auto second = rejuvenation->arm_timer(period(svc));
      (void)verdicts->publish(record(svc, static_cast<double>(cycles), second ? 0 : 1, second ? 0 : second.error().wire_error));
    }
  };
  // Takes a checkpoint; a restored image counts the cycle in the persistent cell and checkpoints again.
  const auto take = [&]() {
    for (;;) {
      auto r = svc.checkpoint();
      if (!r) {
        svc.logf(LogLevel::Error, "checkpoint: %s", r.error().to_string().c_str());
        return;
      }
      if (r->kind == CheckpointOutcome::Kind::Taken) {
        if (by_timer && cycles < max_cycles) arm();
        return;
      }
      cycles = read_cycles() + 1;
      if (auto cell = svc.persistent("cycles")) (void)cell->write(std::as_bytes(std::span(&cycles, 1)));
    }
  };
  auto timer = svc.every(period(svc), [&] {
    ++step;
    for (int i = 0; i < burst; ++i) {
      (void)out->publish(record(svc, static_cast<double>(++sequence), static_cast<double>(cycles),
                                static_cast<double>(step)));
    }
    if (step == checkpoint_at) take();
    if (!by_timer && step >= rollback_at && cycles < max_cycles) {
      if (auto rejuvenation = svc.rejuvenation()) (void)rejuvenation->roll_back();
    }
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

int run_listener(Service& svc) {
  auto out = svc.advertise<Record>("echoes");
  if (!out) return fail(svc, "advertise echoes: " + out.error().to_string());
  std::uint64_t received = 0;
  auto in = svc.subscribe<Record>("numbers", [&](const Record& r) {
    ++received;
    (void)out->publish(record(svc, r.pressure_pa, static_cast<double>(received), svc.epoch().value()));
  });
  if (!in) return fail(svc, "subscribe numbers: " + in.error().to_string());
  return svc.run();
}

std::atomic<std::uint32_t> g_incarnation{0};

int run_worker(Service& svc) {
  auto verdicts = svc.advertise<Record>("verdicts");
  if (!verdicts) return fail(svc, "advertise verdicts: " + verdicts.error().to_string());
  auto spawned = svc.spawn_worker([](rejuv::sdk::WorkerContext& ctx) {
    g_incarnation.store(ctx.incarnation());
    while (ctx.park_point()) std::this_thread::sleep_for(std::chrono::microseconds(200));
  });
  if (!spawned) return fail(svc, "spawn_worker: " + spawned.error().to_string());
  auto timer = svc.every(period(svc), [&] {
    // How many worker threads run is counted from outside (the test reads /proc/<pid>/task): a service may
    // open nothing once booted (docs/design.md §7 "Protection"), and its own bookkeeping is copied into its images.
    (void)verdicts->publish(record(svc, -1, 0, g_incarnation.load()));
  });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

int run_hooked(Service& svc) {
  auto verdicts = svc.advertise<Record>("verdicts");
  if (!verdicts) return fail(svc, "advertise verdicts: " + verdicts.error().to_string());
  svc.on_restored([&](rejuv::Epoch epoch) {
    (void)verdicts->publish(
        record(svc, rejuv::test_services::kRestoredMark, epoch.value(), svc.epoch().value()));
  });
  auto timer =
      svc.every(period(svc), [&] { (void)verdicts->publish(record(svc, 0, svc.epoch().value(), 0)); });
  if (!timer) return fail(svc, "timer: " + timer.error().to_string());
  return svc.run();
}

}  // namespace

int main() {
  auto connected = Service::connect();
  if (!connected) return rejuv::sdk::report_connect_failure(connected.error());
  Service& s = **connected;
  const std::string role(s.text_param("role", ""));
  if (role == "counter") return run_counter(s);
  if (role == "listener" || role == "driver") return run_listener(s);
  if (role == "worker") return run_worker(s);
  if (role == "hooked") return run_hooked(s);
  if (role == "idle") return s.run();
  return fail(s, "unknown role '" + role + "'");
}
