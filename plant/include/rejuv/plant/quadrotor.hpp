// The quadrotor of the plant (docs/design.md §9): parameters, state, the "+" mixer of §IV-B and a 6-DOF rigid body
// integrated with RK4. Frames: N = local NED (z down, so 3 m altitude is p_z = -3), B = body FRD; q_NB is the
// Hamilton quaternion that rotates B-frame vectors into N.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rejuv/core/time.hpp"

namespace rejuv::plant {

// Physical parameters of the vehicle. `jmavsim_default()` is the default quad of jMAVSim (§VI-A), read from
// jMAVSim's Simulator.buildMulticopter(): Quadcopter(..., armLength 0.33/2, rotorThrust 4.0, rotorTorque
// 0.05, rotorTimeConst 0.005), inertia diag(0.005, 0.005, 0.009), mass 0.8, dragMove 0.01. jMAVSim's airflow
// drag is quadratic (F = -c |v_air| v_air); this model uses the linear law F = -c v_air with the same
// coefficient.
struct QuadParams {
  double mass_kg;
  Eigen::Matrix3d inertia_B_kg_m2;
  double arm_length_m;              // L of the mixer (§IV-B): centre to rotor
  double max_thrust_per_motor_N;    // k1 (§IV-B): thrust of one rotor at U_i = 1
  double max_torque_per_motor_N_m;  // k2 (§IV-B): reaction torque of one rotor at U_i = 1
  double motor_time_constant_s;     // first-order lag of each rotor level
  double drag_coefficient_N_s_m;    // linear drag F_N = -c (v_NB_N - wind_N)
  double gravity_m_s2 = 9.81;
  double ground_friction = 0.5;  // Coulomb coefficient μ while resting on the ground (assumed)

  [[nodiscard]] static QuadParams jmavsim_default();
  // Rotor level at which the four rotors together carry the weight: m g / (4 k1).
  [[nodiscard]] double hover_level() const;
};

// Full physical state of the vehicle. motor_level holds the actual normalised rotor levels U_i ∈ [0, 1] after
// the motor lag (what the rotors produce), not the command.
struct QuadState {
  Eigen::Vector3d p_NB_N = Eigen::Vector3d::Zero();  // position, m
  Eigen::Vector3d v_NB_N = Eigen::Vector3d::Zero();  // velocity, m/s
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d omega_B_rad_s = Eigen::Vector3d::Zero();  // body rate of B in N, expressed in B
  Eigen::Vector4d motor_level = Eigen::Vector4d::Zero();
};

// The "+" mixer matrix of §IV-B and its inverse. Rotor 1 is on +x (front), 2 on +y (right), 3 on -x (back),
// 4 on -y (left); rotors 2 and 4 turn counter-clockwise seen from above, so their reaction torque yaws the
// body positively (nose right) about z_B (down):
//   F = k1 ΣU;  τφ = L k1 (U4 − U2);  τθ = L k1 (U1 − U3);  τψ = k2 (−U1 + U2 − U3 + U4).
// F is the total thrust magnitude (acting along −z_B); torques are about the FRD body axes, N·m.
class Mixer {
 public:
  explicit Mixer(const QuadParams& params);
  // u = [F_N, tau_phi_N_m, tau_theta_N_m, tau_psi_N_m] from rotor levels U.
  [[nodiscard]] Eigen::Vector4d wrench_from_motors(const Eigen::Vector4d& U) const;
  // Exact inverse of wrench_from_motors (unclamped: a result may lie outside [0, 1]).
  [[nodiscard]] Eigen::Vector4d motors_from_wrench(const Eigen::Vector4d& u) const;
  [[nodiscard]] const Eigen::Matrix4d& matrix() const { return M_; }
  [[nodiscard]] const Eigen::Matrix4d& inverse() const { return M_inv_; }

 private:
  Eigen::Matrix4d M_;
  Eigen::Matrix4d M_inv_;
};

// 6-DOF rigid-body quadrotor: gravity, rotor thrust and torques through the mixer, first-order rotor lag
// (integrated exactly), linear drag against the air (wind), RK4 on position/velocity/attitude/rate, the
// quaternion renormalised every step, and ground contact at z_N = 0 (cannot go below; downward velocity
// zeroed; Coulomb friction on the horizontal velocity while resting). A copyable value type: copying
// checkpoints the physics.
class Quadrotor {
 public:
  Quadrotor(const QuadParams& params, const QuadState& initial);

  // Advances by dt (1 ms nominal). motor_command holds U_i, clamped to [0, 1]; wind_N_m_s is the air
  // velocity.
  void step(Seconds dt, const Eigen::Vector4d& motor_command,
            const Eigen::Vector3d& wind_N_m_s = Eigen::Vector3d::Zero());

  [[nodiscard]] const QuadState& state() const { return state_; }
  [[nodiscard]] const QuadParams& params() const { return params_; }
  [[nodiscard]] const Mixer& mixer() const { return mixer_; }
  // Mean true acceleration over the last step, m/s² in N (includes ground reaction); for the accelerometer.
  [[nodiscard]] Eigen::Vector3d acceleration_N() const { return a_NB_N_; }
  // Whether the last step ended resting on (or pressed against) the ground.
  [[nodiscard]] bool on_ground() const { return on_ground_; }

  // A trimmed hover at p_NB_N: level, at rest, rotors already at the hover level.
  [[nodiscard]] static QuadState hover_at(const QuadParams& params, const Eigen::Vector3d& p_NB_N);

 private:
  QuadParams params_;
  Mixer mixer_;
  Eigen::Matrix3d inertia_inv_B_;  // I⁻¹, cached: the step runs at 1 kHz
  QuadState state_;
  Eigen::Vector3d a_NB_N_ = Eigen::Vector3d::Zero();
  bool on_ground_ = false;
};

}  // namespace rejuv::plant
