// The linear hover model of the quadrotor that every controller of the SR scheme is designed on (docs/design.md §9,
// paper §IV-B), and the 12-state vocabulary shared by the controllers, the safety ellipsoid, the attack law
// and the setpoint generator.
//
// State x ∈ R¹² = [p_N (m), v_N (m/s), (φ, θ, ψ) (rad, ZYX Euler angles of q_NB), ω_B (rad/s)];
// input u ∈ R⁴ = [F (N, total thrust along −z_B), τφ, τθ, τψ (N·m, about the FRD body axes)] — the vector that
// the mixer of §IV-B maps from the rotor levels U ∈ [0, 1]⁴. Frames: N = local NED, B = body FRD.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::flight {

inline constexpr Eigen::Index kStateDim = 12;
inline constexpr Eigen::Index kInputDim = 4;

using StateVec = Eigen::Matrix<double, kStateDim, 1>;
using InputVec = Eigen::Matrix<double, kInputDim, 1>;
using StateMat = Eigen::Matrix<double, kStateDim, kStateDim>;
using InputMat = Eigen::Matrix<double, kStateDim, kInputDim>;
using GainMat = Eigen::Matrix<double, kInputDim, kStateDim>;

// Where each 3-block starts in x.
namespace idx {
inline constexpr Eigen::Index kPos = 0;    // p_N, m
inline constexpr Eigen::Index kVel = 3;    // v_N, m/s
inline constexpr Eigen::Index kAtt = 6;    // φ, θ, ψ, rad
inline constexpr Eigen::Index kRate = 9;   // ω_B, rad/s
inline constexpr Eigen::Index kYaw = 8;    // ψ
inline constexpr Eigen::Index kThrust = 0;  // F in u
}  // namespace idx

// The physical parameters the control design needs (a subset of plant::QuadParams, kept separate so the
// control library does not depend on the simulator). Units in the names.
struct VehicleParams {
  double mass_kg = 0.8;
  Eigen::Vector3d inertia_diag_kg_m2{0.005, 0.005, 0.009};
  double gravity_m_s2 = 9.81;
  double k1_N = 4.0;       // max thrust of one rotor (§IV-B)
  double k2_N_m = 0.05;    // max reaction torque of one rotor (§IV-B)
  double arm_m = 0.165;    // L of the mixer (§IV-B)
};

// ẋ = A (x − x_eq) + B (u − u_hover), continuous time, about hover at any position and yaw 0.
struct LinearModel {
  StateMat A = StateMat::Zero();
  InputMat B = InputMat::Zero();
};

// x[k+1] − x_eq = A (x[k] − x_eq) + B (u[k] − u_hover) with u held over one period (zero-order hold).
struct DiscreteModel {
  StateMat A = StateMat::Zero();
  InputMat B = InputMat::Zero();
  Seconds period{0};
};

enum class ModelError : std::uint8_t { BadParameter, NotConverged };
struct ModelFailure {
  ModelError kind;
  std::string message;
};

// Validates the parameters (positive, finite) so that a bad file never reaches the algebra.
[[nodiscard]] Result<VehicleParams, ModelFailure> validate(const VehicleParams& params);

// Linearisation about hover: ṗ = v; v̇ = g (−θ, φ, 0) − (δF/m) e_z; (φ̇, θ̇, ψ̇) = ω; ω̇ = J⁻¹ τ.
[[nodiscard]] LinearModel hover_linearisation(const VehicleParams& params);

// Zero-order-hold discretisation: exp([[A, B], [0, 0]] T) = [[A_d, B_d], [0, I]], by its Taylor series (the hover
// A is nilpotent, so the series is exact after a few terms; the loop still checks convergence).
[[nodiscard]] Result<DiscreteModel, ModelFailure> discretise_zoh(const LinearModel& model, Seconds period);

// u_hover = [m g, 0, 0, 0].
[[nodiscard]] InputVec hover_input(const VehicleParams& params);

// Wraps an angle to (−π, π].
[[nodiscard]] double wrap_angle_rad(double angle_rad);

// ZYX Euler angles (φ roll, θ pitch, ψ yaw) of q_NB; θ is clamped to ±π/2 at the singularity.
[[nodiscard]] Eigen::Vector3d euler_from_quaternion(const Eigen::Quaterniond& q_NB);

// Packs the 12-vector.
[[nodiscard]] StateVec make_state(const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_m_s,
                                  const Eigen::Vector3d& euler_rad, const Eigen::Vector3d& omega_B_rad_s);

// A hover setpoint: position and yaw, everything else 0.
[[nodiscard]] StateVec hover_setpoint(const Eigen::Vector3d& p_N_m, double yaw_rad);

// x − x_ref with the yaw difference wrapped to (−π, π] (the only angle that can wind up in flight).
[[nodiscard]] StateVec state_error(const StateVec& x, const StateVec& x_ref);

}  // namespace rejuv::flight
