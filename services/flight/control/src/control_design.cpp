#include "rejuv/flight/control_design.hpp"

namespace rejuv::flight {

StateVec bryson_state_weights(double position_m, double velocity_m_s, double tilt_rad, double yaw_rad,
                              double tilt_rate_rad_s, double yaw_rate_rad_s) {
  const auto w = [](double excursion) { return 1.0 / (excursion * excursion); };
  StateVec q;
  q << Eigen::Vector3d::Constant(w(position_m)), Eigen::Vector3d::Constant(w(velocity_m_s)), w(tilt_rad), w(tilt_rad),
      w(yaw_rad), w(tilt_rate_rad_s), w(tilt_rate_rad_s), w(yaw_rate_rad_s);
  return q;
}

InputVec bryson_input_weights(const InputVec& acceptable_u) {
  return acceptable_u.array().square().inverse().matrix();
}

InputVec input_weights_from_limits(const InputBox& box, const InputVec& u_hover) {
  const InputVec half = (box.hi - u_hover).cwiseMin(u_hover - box.lo);
  return bryson_input_weights(half);
}

StateVec ControlDesignSpec::default_mission_state_weights() {
  // 5 cm, 20 cm/s, 0.05 rad tilt, 0.1 rad yaw, 0.3 rad/s: the small corrections of hover-to-hover tracking. The
  // position weight matters most: the loop has no integrator, so a tilt-estimate bias δ (the EKF cannot tell a
  // level-hover tilt from an accelerometer bias) leaves a steady offset ≈ (K_θ/K_p) δ; 10 cm made it 5–6 cm on
  // some seeds, 5 cm keeps d̄ at 3–4.5 cm. Stiffer still (3 cm) limit-cycles and diverges inside the tiny Ū.
  return bryson_state_weights(0.05, 0.2, 0.05, 0.1, 0.3, 0.3);
}

LqrWeights ControlDesignSpec::default_safety_weights() {
  // States on the scale of the safety box; torques on 0.1 N·m (15 % of U) rather than the full 0.66 N·m: with
  // the full range as the scale the loop answers sensor noise with ±0.1 N·m kicks (±0.3 rad/s of jitter).
  InputVec acceptable_u;
  acceptable_u << 8.0, 0.1, 0.1, 0.033;
  return LqrWeights{.q_diag = bryson_state_weights(1.0, 1.0, 0.5, 0.5, 5.0, 5.0),
                    .r_diag = bryson_input_weights(acceptable_u)};
}

std::string to_string(DesignError error) {
  switch (error) {
    case DesignError::Vehicle: return "vehicle parameters";
    case DesignError::Model: return "hover model";
    case DesignError::Limits: return "actuator limits";
    case DesignError::MissionLqr: return "mission LQR";
    case DesignError::SafetyLqr: return "safety LQR";
    case DesignError::Ellipsoid: return "safety ellipsoid";
  }
  return "unknown";
}

std::string DesignFailure::to_string() const { return flight::to_string(kind) + ": " + message; }

Result<ControlDesign, DesignFailure> design_control(const ControlDesignSpec& spec) {
  auto vehicle = validate(spec.vehicle);
  if (!vehicle) return fail(DesignFailure{DesignError::Vehicle, vehicle.error().message});
  const LinearModel continuous = hover_linearisation(*vehicle);
  auto discrete = discretise_zoh(continuous, spec.control_period);
  if (!discrete) return fail(DesignFailure{DesignError::Model, discrete.error().message});
  auto restricted = restricted_limits(*vehicle, spec.restricted_limit_fraction);
  if (!restricted) return fail(DesignFailure{DesignError::Limits, restricted.error().message});
  const InputVec u_hover = hover_input(*vehicle);
  const InputBox full = full_limits(*vehicle);
  const LqrWeights mission_weights{.q_diag = spec.mission_q_diag,
                                   .r_diag = input_weights_from_limits(*restricted, u_hover)};
  auto mission = LqrController::design(*discrete, mission_weights, u_hover, *restricted);
  if (!mission) return fail(DesignFailure{DesignError::MissionLqr, mission.error().message});
  auto safety = LqrController::design(*discrete, spec.safety, u_hover, full);
  if (!safety) return fail(DesignFailure{DesignError::SafetyLqr, safety.error().message});
  // P certifies the safety controller's loop (the one that must bring the state back after RB); its Lyapunov
  // weight is fitted so that E(1) fills the state box on every axis.
  auto ellipsoid = SafetyEllipsoid::fitted_to_box(safety->closed_loop(), spec.box);
  if (!ellipsoid) return fail(DesignFailure{DesignError::Ellipsoid, ellipsoid.error().message});
  return ControlDesign{.vehicle = *vehicle,
                       .continuous = continuous,
                       .discrete = *discrete,
                       .u_hover = u_hover,
                       .full = full,
                       .restricted = *restricted,
                       .mission_weights = mission_weights,
                       .mission = *mission,
                       .safety = *safety,
                       .ellipsoid = *ellipsoid};
}

}  // namespace rejuv::flight
