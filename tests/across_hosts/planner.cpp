// The companion's planner of launch/quad_multihost (and of planner_test.cpp): a tiny SDK service on the companion
// host that sends the vehicle a mission of its own, one waypoint off the graph's square, on `mission_upload`, the
// topic the ground's uploads arrive on through ext_link (a DATA topic: commander validates it, gen_set_point flies
// it from the next setpoint update). It reaches the vehicle only through the two links (companion → DDS with DDS
// Security → vehicle), in MC only.
//
// Each sample is stamped with its write time, CLOCK_MONOTONIC [ns] in `timestamp_ns` (one clock for every network
// namespace of one machine, the clock of the vehicle kernel's events.csv `wall_s`), so that what the vehicle's
// kernel routed can be set against the vehicle's mode trace: a sample written while the vehicle was in its secure
// interval must reach no vehicle service. Once a second it logs what it wrote:
//   "planner: wrote N mission uploads (waypoint N E D m); stamps [monotonic ns]: s1 s2 ..."
#include <time.h>

#include <chrono>
#include <cstdint>
#include <string>

#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"

namespace {

// The planner's waypoint [m, NED]: 0.5 m south and 0.5 m west of the square's corner (0, 0), at its 3 m, so
// that a vehicle there is flying the planner's mission and no leg of the graph's own square.
constexpr double kNorth = -0.5, kEast = -0.5, kDown = -3.0;

std::uint64_t monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace

int main() {
  using namespace rejuv;
  return sdk::run_service([](sdk::Service& svc) {
    auto uploads = svc.advertise<rejuv_msg_MissionWaypoints>("mission_upload");
    if (!svc.require(uploads, "mission_upload")) return 1;
    std::uint64_t written = 0;
    std::string stamps;  // the stamps written since the last report
    // Every 50 ms, so that several samples fall in each of the vehicle's secure intervals (T_est + t_min ≥ 70 ms).
    auto send = svc.every(std::chrono::milliseconds(50), [&] {
      rejuv_msg_MissionWaypoints m{};
      m.count = 1;
      m.waypoints[0].p_N_m[0] = kNorth;
      m.waypoints[0].p_N_m[1] = kEast;
      m.waypoints[0].p_N_m[2] = kDown;
      m.acceptance_radius_m = 0.1;
      m.timestamp_ns = monotonic_ns();
      if (auto ok = uploads->publish(m); !ok) {
        svc.log(sdk::LogLevel::Warn, "mission upload not written: " + ok.error().to_string());
        return;
      }
      ++written;
      stamps += " " + std::to_string(m.timestamp_ns);
    });
    auto report = svc.every(std::chrono::seconds(1), [&] {
      svc.logf(sdk::LogLevel::Info, "planner: wrote %llu mission uploads (waypoint %g %g %g m); stamps [monotonic ns]:%s",
               static_cast<unsigned long long>(written), kNorth, kEast, kDown, stamps.c_str());
      stamps.clear();
    });
    if (!svc.require_all("timer", send, report)) return 1;
    return svc.run();
  });
}
