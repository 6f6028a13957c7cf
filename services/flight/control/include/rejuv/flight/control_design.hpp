// Everything the SR scheme computes once at start from the vehicle and the SR parameters (docs/design.md §9):
// the discrete hover model at the control rate, the mission LQR (clamped to Ū), the safety LQR (full limits U),
// the safety ellipsoid P and both limit boxes. Design choices and their reasons are in docs/control.md.
#pragma once

#include <cstdint>
#include <string>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/flight/ellipsoid.hpp"
#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight/limits.hpp"
#include "rejuv/flight/lqr_controller.hpp"

namespace rejuv::flight {

// The numbers behind the design; the defaults are this project's tuning of the §VI-C experiment (reasons in
// docs/control.md).
struct ControlDesignSpec {
  VehicleParams vehicle;
  // 250 Hz: the IMU rate of the sensor suite and close to PX4's ≈2 ms control updates (§VI-B); the hover modes
  // are below 10 Hz, so the ZOH at 4 ms costs little phase.
  Seconds control_period{0.004};
  // Mission controller (MC): Bryson state weights; its input weights are not free but 1/ū_j², ū_j the half-width
  // of Ū on axis j, so that in normal flight it asks for what Ū allows instead of saturating (a heavily saturated
  // LQR limit-cycles, and Ū is small).
  StateVec mission_q_diag = default_mission_state_weights();
  // Safety controller (SC): firm on the state, soft on the torques (its output is held during CP, §II, and a
  // jittery one hands a spinning vehicle to MC); its closed loop defines P.
  LqrWeights safety = default_safety_weights();
  StateBox box;  // |e_i| ≤ b_i, the box the safety ellipsoid is fitted into (E(1) ⊂ box)
  double restricted_limit_fraction = graph_values::kRestrictedLimitFraction.fallback;  // Ū / U

  [[nodiscard]] static StateVec default_mission_state_weights();
  [[nodiscard]] static LqrWeights default_safety_weights();
};

// Bryson's rule: q_i = 1/(acceptable excursion)², per state group, and r_j = 1/(acceptable input)².
[[nodiscard]] StateVec bryson_state_weights(double position_m, double velocity_m_s, double tilt_rad, double yaw_rad,
                                            double tilt_rate_rad_s, double yaw_rate_rad_s);
[[nodiscard]] InputVec bryson_input_weights(const InputVec& acceptable_u);
// 1/ū² with ū the half-width of `box` about u_hover on each axis (the smaller side for F).
[[nodiscard]] InputVec input_weights_from_limits(const InputBox& box, const InputVec& u_hover);

enum class DesignError : std::uint8_t { Vehicle, Model, Limits, MissionLqr, SafetyLqr, Ellipsoid };
[[nodiscard]] std::string to_string(DesignError error);
struct DesignFailure {
  DesignError kind;
  std::string message;
  [[nodiscard]] std::string to_string() const;
};

struct ControlDesign {
  VehicleParams vehicle;
  LinearModel continuous;
  DiscreteModel discrete;
  InputVec u_hover;
  InputBox full;        // U
  InputBox restricted;  // Ū
  LqrWeights mission_weights;  // as used (R from Ū)
  LqrController mission;
  LqrController safety;
  SafetyEllipsoid ellipsoid;
};

[[nodiscard]] Result<ControlDesign, DesignFailure> design_control(const ControlDesignSpec& spec);

}  // namespace rejuv::flight
