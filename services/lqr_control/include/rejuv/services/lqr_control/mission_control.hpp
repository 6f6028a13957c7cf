// The `lqr_control` service (paper §IV-B: replaces PX4's mc_att_control + mc_rate_control; docs/design.md §8): the
// mission controller of the simulation — the mission LQR of flight::ControlDesign, saturated to the
// restricted limits Ū — run on every new estimate.
//
// Topics: in vehicle_state (every IMU tick), setpoint (on change; until the first one, the mission's first
// waypoint, where the setpoint generator starts); out actuator_controls, one per estimate, stamped with the
// estimate's time and the publisher's rollback epoch. The policy grants the publish in MC only (in the SEI
// safety_control drives): main.cpp publishes only when the mode allows it, so an honest lqr_control never
// causes a denial. Params (graph-wide, flight_io/params.hpp): sr.box.*, sr.restricted_limit_fraction (the
// design), mission.* (the first waypoint); gains and rate are the simulation's.
//
// Attack hook (docs/design.md §9): compiled only with REJUV_ATTACK_HOOKS. It sees x̂, x_sp and the honest u and
// may replace u; the attacks themselves live with the attack plan, not here.
#pragma once

#include <functional>
#include <optional>

#include "rejuv/core/ids.hpp"
#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::sdk {
class Service;
}  // namespace rejuv::sdk

namespace rejuv::services {

class MissionControl {
 public:
  // `initial_setpoint`: x_sp until the first setpoint message — the generator's own start, the mission's
  // first waypoint (flight::SetpointGenerator starts there), so the vehicle is held where it took off even
  // in a mode in which gen_set_point may not publish (without SR the mode is MC for ever).
  explicit MissionControl(const flight::ControlDesign& design,
                          std::optional<flight::StateVec> initial_setpoint = std::nullopt);

  // The latest setpoint; a non-finite one is refused and the previous one kept.
  Result<void, flight_io::InputFailure> on_setpoint(const rejuv_msg_Setpoint& message);
  // A new estimate → u = sat_Ū(u_hover − K (x̂ − x_sp)); nullopt while no setpoint is known.
  [[nodiscard]] Result<std::optional<rejuv_msg_ActuatorControls>, flight_io::InputFailure> on_state(
      const rejuv_msg_VehicleStateEstimate& message, Epoch epoch);

  [[nodiscard]] const flight::LqrController& controller() const { return mission_; }
  [[nodiscard]] const std::optional<flight::StateVec>& setpoint() const { return x_sp_; }

#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK (test builds only) ====
  // Called with x̂, x_sp and the honest u on every control step; a returned value replaces u. A rollback
  // wipes whatever the hook changed, like any other corruption of the image (docs/design.md §9).
  using AttackHook = std::function<std::optional<flight::InputVec>(
      const flight::StateVec& x_hat, const flight::StateVec& x_sp, const flight::InputVec& u)>;
  void set_attack_hook(AttackHook hook) {
    attack_hook_ = std::move(hook);
  }
  // Called at the start of every control step; a returned gain is written over the mission controller's K in
  // this object and left there (the attack library's GAIN_OVERWRITE, arm_library_attack).
  using GainHook = std::function<std::optional<flight::GainMat>()>;
  void set_gain_hook(GainHook hook) { gain_hook_ = std::move(hook); }
#endif

 private:
  flight::LqrController mission_;
  std::optional<flight::StateVec> x_sp_;
#if defined(REJUV_ATTACK_HOOKS)
  AttackHook attack_hook_;
  GainHook gain_hook_;
#endif
};

// The attack library on lqr_control (docs/control.md "Attack library", flight/attack_library.hpp):
// GAIN_OVERWRITE, the mission controller's gain matrix overwritten by −m·K at the start of an attacked MC
// window and left so: only the rollback to the clean image restores it. Armed at boot by
// services::arm_attack (service_main.hpp), which calls this in a test build; defined in gain_attack.cpp.
[[nodiscard]] bool arm_library_attack(sdk::Service& svc, MissionControl& control);

}  // namespace rejuv::services
