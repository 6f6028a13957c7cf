#include "rejuv/flight/hover_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace rejuv::flight {
namespace {

bool positive_finite(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

Result<VehicleParams, ModelFailure> validate(const VehicleParams& params) {
  const auto bad = [](std::string what) { return fail(ModelFailure{ModelError::BadParameter, std::move(what)}); };
  if (!positive_finite(params.mass_kg)) return bad("mass_kg must be positive and finite");
  for (Eigen::Index i = 0; i < 3; ++i) {
    if (!positive_finite(params.inertia_diag_kg_m2[i])) return bad("inertia_diag_kg_m2 must be positive and finite");
  }
  if (!positive_finite(params.gravity_m_s2)) return bad("gravity_m_s2 must be positive and finite");
  if (!positive_finite(params.k1_N)) return bad("k1_N (max thrust per rotor) must be positive and finite");
  if (!positive_finite(params.k2_N_m)) return bad("k2_N_m (max torque per rotor) must be positive and finite");
  if (!positive_finite(params.arm_m)) return bad("arm_m (L) must be positive and finite");
  if (4.0 * params.k1_N <= params.mass_kg * params.gravity_m_s2) {
    return bad("the four rotors cannot lift the vehicle: 4 k1 <= m g");
  }
  return params;
}

LinearModel hover_linearisation(const VehicleParams& params) {
  LinearModel m;
  const double g = params.gravity_m_s2;
  m.A.block<3, 3>(idx::kPos, idx::kVel).setIdentity();  // ṗ = v
  // Thrust −F R e_z with R ≈ I + [φ θ ψ]×: tilting by θ (nose up) tips thrust to −x, rolling by φ to +y.
  m.A(idx::kVel + 0, idx::kAtt + 1) = -g;
  m.A(idx::kVel + 1, idx::kAtt + 0) = g;
  m.A.block<3, 3>(idx::kAtt, idx::kRate).setIdentity();  // Euler rates = ω_B at hover
  m.B(idx::kVel + 2, idx::kThrust) = -1.0 / params.mass_kg;  // more thrust accelerates up (−z in NED)
  for (Eigen::Index i = 0; i < 3; ++i) {
    m.B(idx::kRate + i, 1 + i) = 1.0 / params.inertia_diag_kg_m2[i];  // ω̇ = J⁻¹ τ (no gyroscopic term at ω = 0)
  }
  return m;
}

Result<DiscreteModel, ModelFailure> discretise_zoh(const LinearModel& model, Seconds period) {
  const double T = period.count();
  if (!positive_finite(T)) {
    return fail(ModelFailure{ModelError::BadParameter, "control period must be positive and finite"});
  }
  constexpr Eigen::Index n = kStateDim + kInputDim;
  using Big = Eigen::Matrix<double, n, n>;
  Big M = Big::Zero();
  M.topLeftCorner<kStateDim, kStateDim>() = model.A * T;
  M.topRightCorner<kStateDim, kInputDim>() = model.B * T;
  Big term = Big::Identity();
  Big sum = Big::Identity();
  bool converged = false;
  for (int k = 1; k <= 60; ++k) {
    term = term * M / static_cast<double>(k);
    sum += term;
    if (term.norm() <= 1e-18 * sum.norm()) {
      converged = true;
      break;
    }
  }
  if (!converged || !sum.allFinite()) {
    return fail(ModelFailure{ModelError::NotConverged,
                             "matrix exponential series did not converge (period too long for the model?)"});
  }
  DiscreteModel d;
  d.A = sum.topLeftCorner<kStateDim, kStateDim>();
  d.B = sum.topRightCorner<kStateDim, kInputDim>();
  d.period = period;
  return d;
}

InputVec hover_input(const VehicleParams& params) {
  InputVec u = InputVec::Zero();
  u[idx::kThrust] = params.mass_kg * params.gravity_m_s2;
  return u;
}

double wrap_angle_rad(double angle_rad) {
  constexpr double kPi = std::numbers::pi;
  double a = std::remainder(angle_rad, 2.0 * kPi);  // in [−π, π]
  if (a <= -kPi) a += 2.0 * kPi;
  return a;
}

Eigen::Vector3d euler_from_quaternion(const Eigen::Quaterniond& q_NB) {
  const Eigen::Quaterniond q = q_NB.normalized();
  const double w = q.w(), x = q.x(), y = q.y(), z = q.z();
  // ZYX (yaw–pitch–roll) convention: R = Rz(ψ) Ry(θ) Rx(φ).
  const double roll = std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
  const double sin_pitch = std::clamp(2.0 * (w * y - z * x), -1.0, 1.0);
  const double pitch = std::asin(sin_pitch);
  const double yaw = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
  return {roll, pitch, yaw};
}

StateVec make_state(const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_m_s, const Eigen::Vector3d& euler_rad,
                    const Eigen::Vector3d& omega_B_rad_s) {
  StateVec x;
  x << p_N_m, v_N_m_s, euler_rad, omega_B_rad_s;
  return x;
}

StateVec hover_setpoint(const Eigen::Vector3d& p_N_m, double yaw_rad) {
  StateVec x = StateVec::Zero();
  x.segment<3>(idx::kPos) = p_N_m;
  x[idx::kYaw] = yaw_rad;
  return x;
}

StateVec state_error(const StateVec& x, const StateVec& x_ref) {
  StateVec e = x - x_ref;
  e[idx::kYaw] = wrap_angle_rad(e[idx::kYaw]);
  return e;
}

}  // namespace rejuv::flight
