// The attack library (docs/control.md "Attack library"): the laws of the attacks that reach the
// vehicle through another compromised service than the controller (§II: "the attacker … changes the control
// inputs indirectly, through the sensor readings and the state estimate"), one law per kind of idl/launch.proto
// AttackKind 13–17, beside the worst-case control of §VI-D (attack.hpp). The model (flight/sim sr_sim.cpp) and the
// runtime hooks (services/ekf2, sensors, gen_set_point, lqr_control, test builds) call the same functions, so
// that `rejuv sim` and `rejuv run` compare like with like. Each law is given the time the current MC window has
// been attacked, τ (without SR: since the attack began); the corruption it produces lives in the compromised
// service's memory, so the rollback to the clean image erases it.
//
//   ESTIMATE_SHIFT   x̂' = x̂ + m·d. d (‖d‖_P = 1) is the direction the honest controller follows out of the
//                    safety set fastest: from e = 0, with u = u_h − K(e + δ), ė = −BKδ and V̈ = 2 δᵀKᵀBᵀPBKδ,
//                    so d is the top generalised eigenvector of (KᵀBᵀPBK, P) (continuous B, mission K). The
//                    honest controller then drives x towards x_sp − m·d: V → m² without SR.
//   ESTIMATE_DRIFT   x̂' = x̂ + r·τ·d: the same direction, growing slowly (a drift no single window shows).
//   SENSOR_BIAS      ω_gyro' = ω_gyro + (m, 0, 0) rad/s in every combined IMU sample: the EKF's attitude
//                    drifts about body x, and the controller levels a tilt that is not there.
//   SETPOINT_SHIFT   x_sp' = x_sp + (0, 0, m·τ): x_sp moves down, towards the ground, at m m/s.
//   GAIN_OVERWRITE   K' = −m·K: the controller's gain is overwritten in memory at the start of the window and
//                    left so (positive feedback); the controls are still clamped to Ū by the output driver.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

#include "rejuv/core/time.hpp"
#include "rejuv/flight/control_design.hpp"

namespace rejuv::flight {

// The kinds of AttackKind that act on the vehicle (the model simulates these; proto numbers in comments).
enum class AttackLaw : std::uint8_t {
  WorstCaseControl,  // 1, lqr_control (§VI-D, attack.hpp)
  EstimateShift,     // 13, ekf2
  SensorBias,        // 14, sensors
  SetpointShift,     // 15, gen_set_point
  GainOverwrite,     // 16, lqr_control
  EstimateDrift,     // 17, ekf2
};
inline constexpr std::array kAllAttackLaws{AttackLaw::WorstCaseControl, AttackLaw::EstimateShift,
                                           AttackLaw::SensorBias,       AttackLaw::SetpointShift,
                                           AttackLaw::GainOverwrite,    AttackLaw::EstimateDrift};

// The AttackKind enum name ("ESTIMATE_SHIFT"), its number, and back (exact names; nullopt for any other kind).
[[nodiscard]] std::string_view to_string(AttackLaw law);
[[nodiscard]] int proto_number(AttackLaw law);
[[nodiscard]] std::optional<AttackLaw> attack_law_from_name(std::string_view name);
[[nodiscard]] std::optional<AttackLaw> attack_law_from_number(int number);
// Case-insensitive (the command line's --attack).
[[nodiscard]] std::optional<AttackLaw> attack_law_from_name_icase(std::string_view name);
// "WORST_CASE_CONTROL, ESTIMATE_SHIFT, …" (for errors).
[[nodiscard]] std::string attack_law_names();
// The service of the reference graph a kind compromises (--attack KIND with no service given).
[[nodiscard]] std::string_view default_service(AttackLaw law);
// The kind's magnitude when the plan leaves it 0 (units per kind, header comment); 0 for WORST_CASE_CONTROL.
[[nodiscard]] double default_magnitude(AttackLaw law);
[[nodiscard]] double effective_magnitude(AttackLaw law, double magnitude);

// ESTIMATE_SHIFT / ESTIMATE_DRIFT: the unit-P-norm direction of the header comment (sign: its largest
// component positive).
[[nodiscard]] StateVec fdi_direction(const ControlDesign& design);
// The estimate's offset at τ into the attacked window: m·d (shift) or m·τ·d (drift); zero for other kinds.
[[nodiscard]] StateVec estimate_offset(AttackLaw law, const StateVec& direction, double magnitude, Seconds tau);
// SENSOR_BIAS: what is added to every gyro sample, rad/s in B.
[[nodiscard]] Eigen::Vector3d gyro_bias(double magnitude);
// SETPOINT_SHIFT: what is added to x_sp at τ into the attacked window.
[[nodiscard]] StateVec setpoint_offset(double rate_m_s, Seconds tau);
// GAIN_OVERWRITE: the gain written over K.
[[nodiscard]] GainMat overwritten_gain(const GainMat& K, double magnitude);

}  // namespace rejuv::flight
