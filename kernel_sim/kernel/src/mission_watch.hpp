// The kernel's observers of what it routes, kept out of the routing core (router.cpp only routes). One hook
// feeds them each publication, Router::watch_publication (router.hpp); denials come through drain_denials. Code in
// watch.cpp:
//   - the run's Observer (Observer::on_publication, on_control_update for Fig. 7);
//   - MissionWatch: the mission's end, the first Setpoint a service publishes with mission_done = 1
//     (KernelOptions::stop_on_mission_done ends the run there, else it is logged and the run goes on);
//   - the security events: every capability denial counted, logged and published as a SecurityEvent (docs/design.md §3).
#pragma once

#include <cstddef>
#include <span>

namespace rejuv::kernel {

class MissionWatch {
 public:
  // A service's publication on a Setpoint topic (rejuv::msg::Setpoint): true the first time one reports
  // mission_done, never again.
  [[nodiscard]] bool on_setpoint(std::span<const std::byte> payload);
  [[nodiscard]] bool done() const { return done_; }

 private:
  bool done_ = false;
};

}  // namespace rejuv::kernel
