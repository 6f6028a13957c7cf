// hello_monitor: a service written outside the Rejuv tree (docs/writing_a_service.md). It reads the vehicle's
// state estimate, keeps the highest altitude seen, and publishes the latest estimate at 2 Hz on its own
// topic `monitor_state` (a decimated state for a slow consumer: a ground link, a logger), and a summary of
// its own type hello::Summary (hello.idl, rejuv_add_topics in CMakeLists.txt) on `hello_summary`.
#include <algorithm>
#include <cstdint>

#include "hello.h"  // idlc's C struct hello_Summary
#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"
#if defined(REJUV_ATTACK_HOOKS)
#include "rejuv/sdk/attack_hook.hpp"  // a test build's fault injection (rejuv_add_service ATTACK_HOOKS)
#endif

REJUV_TOPIC_TYPE(hello_Summary, "hello::Summary");

int main() {
  return rejuv::sdk::run_service([](rejuv::sdk::Service& svc) {
    using rejuv::sdk::LogLevel;
    // A launch-graph param (services { params { name: "period_s" number: 0.5 } }), with its default.
    const double period_s = svc.param("period_s", 0.5);
    if (!(period_s >= 0.01 && period_s <= 10.0)) {
      svc.logf(LogLevel::Error, "period_s: expected 0.01 to 10 s, got %g", period_s);
      return 1;
    }

    // The topics this service was granted (hello.policy.pbtxt); a wrong type or a missing grant is an error
    // here, at boot, with the reason.
    auto out = svc.advertise<rejuv_msg_VehicleStateEstimate>("monitor_state");
    if (!svc.require(out, "monitor_state")) return 1;
    auto summary = svc.advertise<hello_Summary>("hello_summary");  // the policy's `types` size is checked here
    if (!svc.require(summary, "hello_summary")) return 1;
    double max_altitude_m = 0.0;
    double altitude_fault_m = 0.0;  // 0 unless a CUSTOM attack corrupted it (test builds only, below)
    auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>(
        "vehicle_state", [&](const rejuv_msg_VehicleStateEstimate& m) {
          max_altitude_m = std::max(max_altitude_m, -m.p_N_m[2] + altitude_fault_m);  // NED: up is −down
        });
    if (!svc.require(state, "vehicle_state")) return 1;

    // After a rollback this process is a restored image (its memory the checkpoint's): said once per
    // rollback.
    svc.on_restored([&](rejuv::Epoch epoch) {
      svc.logf(LogLevel::Info, "hello: restored into epoch %u", epoch.value());
    });
#if defined(REJUV_ATTACK_HOOKS)
    // A launch plan's CUSTOM attack on this service (docs/writing_a_service.md "Injecting a fault into your
    // own service"): from its first attacked window on, every altitude reads `magnitude` m too high — until a
    // rollback restores the clean image.
    auto attack = rejuv::sdk::on_attack(svc, [&](const rejuv::sdk::AttackWindow& w) {
      altitude_fault_m = w.magnitude;
      svc.logf(LogLevel::Warn, "hello: attacked window %u (epoch %u)", w.ordinal, w.epoch.value());
    });
    if (!svc.require(attack, "attack plan")) return 1;
#endif

    std::uint64_t published = 0;
    auto tick = svc.every(rejuv::to_nanos(rejuv::Seconds{period_s}), [&] {
      if (!state->valid()) return;  // nothing received yet
      if (auto ok = out->publish(state->latest()); !ok) {
        svc.log(LogLevel::Warn, "publishing monitor_state: " + ok.error().to_string());
        return;
      }
      ++published;
      const hello_Summary s{.received = state->received(), .published = published, .max_altitude_m = max_altitude_m};
      if (auto ok = summary->publish(s); !ok) {
        svc.log(LogLevel::Warn, "publishing hello_summary: " + ok.error().to_string());
        return;
      }
      if (published == 1 || published % 10 == 0) {
        svc.logf(LogLevel::Info, "hello: %llu states received, %llu published, highest altitude %.2f m",
                 static_cast<unsigned long long>(state->received()), static_cast<unsigned long long>(published),
                 max_altitude_m);
      }
    });
    if (!svc.require(tick, "timer")) return 1;
    return svc.run();  // Ready, then deliveries and timer ticks until the kernel shuts the graph down
  });
}
