#include "rejuv/services/safety_control/safety_control.hpp"

#include <utility>

namespace rejuv::services {

SafetyControl::SafetyControl(const flight::ControlDesign& design,
                             std::optional<flight::StateVec> initial_setpoint)
    : safety_(design.safety), x_sp_(std::move(initial_setpoint)) {}

Result<void, flight_io::InputFailure> SafetyControl::on_setpoint(const rejuv_msg_Setpoint& message) {
  auto x_sp = flight_io::setpoint_from_message(message);
  if (!x_sp) return fail(std::move(x_sp.error()));
  x_sp_ = *x_sp;
  return {};
}

Result<std::optional<rejuv_msg_ActuatorControls>, flight_io::InputFailure> SafetyControl::on_state(
    const rejuv_msg_VehicleStateEstimate& message, Epoch epoch) {
  auto x_hat = flight_io::state_from_message(message);
  if (!x_hat) return fail(std::move(x_hat.error()));
  x_hat_ = *x_hat;
  if (!x_sp_) return std::optional<rejuv_msg_ActuatorControls>{};
  // The simulation's control step in SC and UPDATE (flight/sim: design.safety.control(x̂, x_sp)).
  const flight::InputVec u = safety_.control(*x_hat_, *x_sp_);
  return flight_io::controls_message(u, flight_io::time_of(message.timestamp_ns), epoch);
}

}  // namespace rejuv::services
