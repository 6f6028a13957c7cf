// The `safety_control` service (paper §II "safety controller", §IV; docs/design.md §8): the simulation's safety
// controller — the safety LQR of flight::ControlDesign on the hover linearisation, saturated to the FULL
// actuator limits U — run on every new estimate. Its closed loop is the one the safety ellipsoid P is built
// from, so ‖x − x_sp‖_P decreases under it (§IV-A).
//
// Topics: in vehicle_state (every IMU tick), setpoint (on change; until the first one, the mission's first
// waypoint, where the setpoint generator starts); out actuator_controls, one per estimate (the rate of
// lqr_control), stamped with the estimate's time and the publisher's rollback epoch. The policy grants the
// publish in RB, SC, UPDATE and CP only: main.cpp publishes only while the mode allows it, so an honest
// safety_control never causes a denial and is silent in MC.
//
// Warm state: it consumes every estimate and setpoint in every mode (MC included), so the first controls it
// publishes when it takes over are computed from the latest x̂ and x_sp, exactly what the simulation's SC
// step computes at that instant — no start-up transient, no stale setpoint. The LQR itself is stateless.
// Params (graph-wide, flight_io/params.hpp): sr.box.*, sr.restricted_limit_fraction (the design),
// mission.* (the first waypoint).
#pragma once

#include <cstdint>
#include <optional>

#include "rejuv/core/ids.hpp"
#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::services {

class SafetyControl {
 public:
  // `initial_setpoint`: x_sp until the first setpoint message (as lqr_control's MissionControl).
  explicit SafetyControl(const flight::ControlDesign& design,
                         std::optional<flight::StateVec> initial_setpoint = std::nullopt);

  // The latest setpoint; a non-finite one is refused and the previous one kept.
  Result<void, flight_io::InputFailure> on_setpoint(const rejuv_msg_Setpoint& message);
  // A new estimate → u = sat_U(u_hover − K_s (x̂ − x_sp)); nullopt while no setpoint is known. Computed in
  // every mode; whether it is published is the mode's (main.cpp).
  [[nodiscard]] Result<std::optional<rejuv_msg_ActuatorControls>, flight_io::InputFailure> on_state(
      const rejuv_msg_VehicleStateEstimate& message, Epoch epoch);

  [[nodiscard]] const flight::LqrController& controller() const { return safety_; }
  [[nodiscard]] const std::optional<flight::StateVec>& setpoint() const { return x_sp_; }
  // The latest accepted estimate (nullopt before the first).
  [[nodiscard]] const std::optional<flight::StateVec>& estimate() const { return x_hat_; }

 private:
  flight::LqrController safety_;
  std::optional<flight::StateVec> x_sp_;
  std::optional<flight::StateVec> x_hat_;
};

}  // namespace rejuv::services
