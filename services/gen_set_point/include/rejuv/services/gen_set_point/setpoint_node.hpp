// The `gen_set_point` service (paper §IV-A, §IV-B; docs/design.md §8): the simulation's setpoint generator
// (flight::SetpointGenerator) driven by topics.
//
// Topics: in mission (MissionWaypoints, from commander), vehicle_state (every IMU tick),
// setpoint_update_request (from checkpoint_p's rollback handler, with SR); out setpoint — published when it
// changed (a new mission, a move, the mission done) as soon as the mode allows it (the policy grants the
// publish in the SEI only: in MC a compromised copy cannot steer the vehicle through x_sp).
// Params (graph-wide, flight_io/params.hpp): sr.enabled, sr.rho_m, sr.rho_s, sr.t_min_s, sr.check_period_s,
// sr.box.*, sr.restricted_limit_fraction (P comes from the control design).
//
// With SR (sr.enabled = 1): each setpoint_update_request moves x_sp as far as keeps x̂ ∈ E(ρ_M, x_sp')
// (mode "update" of Fig. 1; ρ_M from the request when it carries one in (0, 1], else sr.rho_m).
// Without SR: the tracking rule of the simulation's no-SR configuration, on every estimate — every
// check_period, unless within t_min of the last move, if ‖x̂ − x_sp‖_P < ρ_s then update; update requests
// are ignored.
// mission_done (as the simulation's completion): once x_sp is the last waypoint and x̂ is within the
// mission's acceptance radius of it, latched; the setpoint carrying it is stamped with the estimate's time
// at which it happened, even if the mode delays the publication.
#pragma once

#include "rejuv/flight_io/mission_record.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "rejuv/flight/ellipsoid.hpp"
#include "rejuv/flight/setpoint.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::sdk {
class Service;
}  // namespace rejuv::sdk

namespace rejuv::services {

class SetpointNode {
 public:
  SetpointNode(const flight::SafetyEllipsoid& ellipsoid, const flight_io::TrackingParams& tracking);

  // A mission (re)starts the generator at its first waypoint; the same mission again changes nothing. Ignored
  // after restore(): the kept record, not the launch graph's mission that commander publishes at boot, says
  // what is being flown.
  Result<void, flight_io::InputFailure> on_mission(const rejuv_msg_MissionWaypoints& message);
  // A cold restart (docs/design.md §7): continue the kept mission where the record says x_sp was, and publish that
  // x_sp (stamped `now`) as soon as the mode allows. Refused (nothing changed) if its mission is no path.
  Result<void, flight_io::InputFailure> restore(const flight_io::MissionRecord& record, Nanos now);
  // A validated mission upload (docs/mavlink.md), applied at a setpoint update: the new path runs from
  // the current x_sp through the uploaded waypoints, so x_sp does not jump; the update rule then moves it.
  // At most kMaxWaypoints − 1 waypoints (the current x_sp is the first). Nothing changes when it is refused
  // or when it is the upload already being flown (the cell keeps an upload until the next one).
  enum class UploadOutcome : std::uint8_t { Applied, Unchanged };
  Result<UploadOutcome, flight_io::InputFailure> apply_upload(const flight_io::MissionSpec& upload, Nanos now);
  // What the kept record should say now (nullopt before a mission).
  [[nodiscard]] std::optional<flight_io::MissionRecord> record() const;
  // The latest x̂; runs the no-SR tracking rule and the completion check.
  Result<void, flight_io::InputFailure> on_state(const rejuv_msg_VehicleStateEstimate& message);
  // publish_update_sp() of Fig. 5. Ignored without SR, before a mission or before the first estimate.
  enum class RequestOutcome : std::uint8_t { Moved, Held, Finished, Ignored };
  RequestOutcome on_update_request(const rejuv_msg_SetpointUpdateRequest& message);

  // The setpoint to publish if it changed since the last take (call only when the publish is allowed).
  [[nodiscard]] std::optional<rejuv_msg_Setpoint> take_changed();

  [[nodiscard]] bool mission_done() const { return done_at_.has_value(); }
  [[nodiscard]] const flight::SetpointGenerator* generator() const {
    return generator_ ? &*generator_ : nullptr;
  }

#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK (test builds only; arm_library_attack) ====
  // Called on every estimate with its time; a returned offset is added to x_sp from then on (a compromised
  // gen_set_point), and the moved x_sp is published as soon as the mode allows. The offset stays in memory
  // until a rollback wipes it, like any other corruption of the image.
  using SetpointHook = std::function<std::optional<flight::StateVec>(Nanos t)>;
  void set_attack_hook(SetpointHook hook) { attack_hook_ = std::move(hook); }
#endif

 private:
  void track_without_sr(Nanos now);
  void check_completion(Nanos now);
  void changed(Nanos now);

  flight::SafetyEllipsoid ellipsoid_;
  flight_io::TrackingParams tracking_;
  std::shared_ptr<const flight::WaypointPath> path_;
  std::optional<flight_io::MissionSpec> mission_;
  std::optional<flight::SetpointGenerator> generator_;
  std::optional<flight::StateVec> x_hat_;
  // No-SR tracker (flight/sim: track_without_sr).
  Nanos next_check_{0};
  Nanos hold_until_{0};
  std::optional<Nanos> done_at_;
  std::optional<Nanos> changed_at_;  // pending publication
  bool restored_ = false;            // from a kept record: on_mission is ignored
#if defined(REJUV_ATTACK_HOOKS)
  SetpointHook attack_hook_;
  flight::StateVec attack_offset_ = flight::StateVec::Zero();
#endif
};

// The attack library on gen_set_point (docs/control.md "Attack library", flight/attack_library.hpp):
// SETPOINT_SHIFT, a compromised generator that moves x_sp down, towards the ground, in attacked MC windows
// (the policy lets it publish in MC). The offset and the window live in this process's memory: the rollback
// erases them. Armed at boot by services::arm_attack (service_main.hpp), which calls this in a test build;
// defined in setpoint_attack.cpp.
[[nodiscard]] bool arm_library_attack(sdk::Service& svc, SetpointNode& node);

}  // namespace rejuv::services
