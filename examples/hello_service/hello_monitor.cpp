// hello_monitor: a service written outside the Rejuv tree (docs/writing_a_service.md). It reads the vehicle's
// state estimate, keeps the highest altitude seen, and publishes the latest estimate at 2 Hz on its own
// topic `monitor_state` (a decimated state for a slow consumer: a ground link, a logger), and a summary of
// its own type hello::Summary (hello.idl, rejuv_add_topics in CMakeLists.txt) on `hello_summary`.
#include <algorithm>
#include <cstdint>

#include "hello.h"  // idlc's C struct hello_Summary
#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"

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
    auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>(
        "vehicle_state", [&](const rejuv_msg_VehicleStateEstimate& m) {
          max_altitude_m = std::max(max_altitude_m, -m.p_N_m[2]);  // NED: up is −down
        });
    if (!svc.require(state, "vehicle_state")) return 1;

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
