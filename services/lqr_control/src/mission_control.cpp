#include "rejuv/services/lqr_control/mission_control.hpp"

#include <utility>

namespace rejuv::services {

MissionControl::MissionControl(const flight::ControlDesign& design,
                               std::optional<flight::StateVec> initial_setpoint)
    : mission_(design.mission), x_sp_(std::move(initial_setpoint)) {}

Result<void, flight_io::InputFailure> MissionControl::on_setpoint(const rejuv_msg_Setpoint& message) {
  auto x_sp = flight_io::setpoint_from_message(message);
  if (!x_sp) return fail(std::move(x_sp.error()));
  x_sp_ = *x_sp;
  return {};
}

Result<std::optional<rejuv_msg_ActuatorControls>, flight_io::InputFailure> MissionControl::on_state(
    const rejuv_msg_VehicleStateEstimate& message, Epoch epoch) {
  auto x_hat = flight_io::state_from_message(message);
  if (!x_hat) return fail(std::move(x_hat.error()));
  if (!x_sp_) return std::optional<rejuv_msg_ActuatorControls>{};
#if defined(REJUV_ATTACK_HOOKS)
  // ==== GAIN HOOK POINT ====
  if (gain_hook_) {
    if (auto K = gain_hook_()) mission_ = mission_.with_gain(*K);
  }
#endif
  // The simulation's control step in MC (flight/sim: design.mission.control(x̂, x_sp)).
  flight::InputVec u = mission_.control(*x_hat, *x_sp_);
#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK POINT ====
  if (attack_hook_) {
    if (auto forged = attack_hook_(*x_hat, *x_sp_, u)) u = *forged;
  }
#endif
  return flight_io::controls_message(u, flight_io::time_of(message.timestamp_ns), epoch);
}

}  // namespace rejuv::services
