// 6-DOF quadrotor with the "+" mixer of §IV-B (docs/design.md §9).
#include "rejuv/plant/quadrotor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "rejuv/core/result.hpp"

namespace rejuv::plant {

QuadParams QuadParams::jmavsim_default() {
  // jMAVSim Simulator.buildMulticopter(): new Quadcopter(world, model, "x", "default", 0.33 / 2, 4.0, 0.05,
  // 0.005, gc); I = diag(0.005, 0.005, 0.009); setMass(0.8); setDragMove(0.01). jMAVSim flies it as an "x"
  // frame; the paper's mixer (§IV-B) is the "+" layout, which is what Mixer implements with the same L, k1,
  // k2.
  QuadParams p{
      .mass_kg = 0.8,
      .inertia_B_kg_m2 = Eigen::Vector3d(0.005, 0.005, 0.009).asDiagonal(),
      .arm_length_m = 0.33 / 2,
      .max_thrust_per_motor_N = 4.0,
      .max_torque_per_motor_N_m = 0.05,
      .motor_time_constant_s = 0.005,
      .drag_coefficient_N_s_m = 0.01,
  };
  return p;
}

double QuadParams::hover_level() const {
  return mass_kg * gravity_m_s2 / (4.0 * max_thrust_per_motor_N);
}

// ----------------------------------------------------------------------------------------------------------
// Mixer

Mixer::Mixer(const QuadParams& params) {
  const double k1 = params.max_thrust_per_motor_N;
  const double k2 = params.max_torque_per_motor_N_m;
  const double L = params.arm_length_m;
  REJUV_ASSERT(k1 > 0 && k2 > 0 && L > 0, "mixer needs k1, k2, L > 0 to be invertible");
  // Rows: F, τφ, τθ, τψ; columns: U1..U4 (§IV-B).
  M_ << k1, k1, k1, k1,       //
      0, -L * k1, 0, L * k1,  //
      L * k1, 0, -L * k1, 0,  //
      -k2, k2, -k2, k2;
  // Closed form of the inverse: each row of M is orthogonal to the others, so M⁻¹ = Mᵀ diag(1/‖row_i‖²).
  const Eigen::Vector4d row_norm2(4 * k1 * k1, 2 * L * L * k1 * k1, 2 * L * L * k1 * k1, 4 * k2 * k2);
  M_inv_ = M_.transpose() * row_norm2.cwiseInverse().asDiagonal();
}

Eigen::Vector4d Mixer::wrench_from_motors(const Eigen::Vector4d& U) const {
  return M_ * U;
}

Eigen::Vector4d Mixer::motors_from_wrench(const Eigen::Vector4d& u) const {
  return M_inv_ * u;
}

// ----------------------------------------------------------------------------------------------------------
// Rigid body

namespace {

// Rigid-body part of the state integrated by RK4: p(3), v(3), q(w, x, y, z)(4), ω(3). Plain doubles with
// hand-written loops: the step runs at 1 kHz inside a simulation that must beat 1000× real time, and at -O2
// the equivalent Eigen expressions on a 13-vector were not inlined (3× slower).
struct Body {
  std::array<double, 13> x;
};

Body pack(const QuadState& s) {
  return Body{{s.p_NB_N.x(), s.p_NB_N.y(), s.p_NB_N.z(), s.v_NB_N.x(), s.v_NB_N.y(), s.v_NB_N.z(), s.q_NB.w(),
               s.q_NB.x(), s.q_NB.y(), s.q_NB.z(), s.omega_B_rad_s.x(), s.omega_B_rad_s.y(),
               s.omega_B_rad_s.z()}};
}

// a + h b, elementwise.
Body axpy(const Body& a, double h, const Body& b) {
  Body out;
  for (std::size_t i = 0; i < out.x.size(); ++i) {
    out.x[i] = a.x[i] + h * b.x[i];
  }
  return out;
}

// What drives the body during one RK4 stage.
struct Forcing {
  double thrust_N;           // total rotor thrust F, along −z_B
  Eigen::Vector3d torque_B;  // [τφ, τθ, τψ], N·m
};

// Time derivative of the rigid-body state: Newton in N for translation, Euler in B for rotation,
// q̇ = ½ q ⊗ (0, ω).
Body derivative(const Body& b, const Forcing& u, const Eigen::Vector3d& wind_N, const QuadParams& params,
                const Eigen::Matrix3d& I_inv) {
  const double* x = b.x.data();
  const double qw = x[6];
  const double qx = x[7];
  const double qy = x[8];
  const double qz = x[9];
  const double wx = x[10];
  const double wy = x[11];
  const double wz = x[12];
  // z_B expressed in N: third column of R(q), divided by |q|² so that intermediate stages need no
  // normalising.
  const double inv_n2 = 1.0 / (qw * qw + qx * qx + qy * qy + qz * qz);
  const double zx = 2.0 * (qx * qz + qw * qy) * inv_n2;
  const double zy = 2.0 * (qy * qz - qw * qx) * inv_n2;
  const double zz = (qw * qw - qx * qx - qy * qy + qz * qz) * inv_n2;
  // Thrust along −z_B, linear drag against the air, gravity along +z_N (NED).
  const double c_m = params.drag_coefficient_N_s_m / params.mass_kg;
  const double F_m = u.thrust_N / params.mass_kg;
  const Eigen::Vector3d w(wx, wy, wz);
  const Eigen::Vector3d Iw = params.inertia_B_kg_m2 * w;
  const Eigen::Vector3d w_dot = I_inv * (u.torque_B - w.cross(Iw));
  return Body{{x[3], x[4], x[5],                                             //
               -F_m * zx - c_m * (x[3] - wind_N.x()),                        //
               -F_m * zy - c_m * (x[4] - wind_N.y()),                        //
               -F_m * zz - c_m * (x[5] - wind_N.z()) + params.gravity_m_s2,  //
               -0.5 * (qx * wx + qy * wy + qz * wz),                         //
               0.5 * (qw * wx + qy * wz - qz * wy),                          //
               0.5 * (qw * wy + qz * wx - qx * wz),                          //
               0.5 * (qw * wz + qx * wy - qy * wx),                          //
               w_dot.x(), w_dot.y(), w_dot.z()}};
}

Forcing forcing(const Mixer& mixer, const Eigen::Vector4d& U) {
  const Eigen::Vector4d u = mixer.wrench_from_motors(U);
  return Forcing{u(0), u.tail<3>()};
}

}  // namespace

Quadrotor::Quadrotor(const QuadParams& params, const QuadState& initial)
    : params_(params), mixer_(params), inertia_inv_B_(params.inertia_B_kg_m2.inverse()), state_(initial) {
  REJUV_ASSERT(params.mass_kg > 0, "mass must be positive");
  REJUV_ASSERT(params.inertia_B_kg_m2.determinant() > 0, "inertia must be positive definite");
  state_.q_NB.normalize();
}

QuadState Quadrotor::hover_at(const QuadParams& params, const Eigen::Vector3d& p_NB_N) {
  QuadState s;
  s.p_NB_N = p_NB_N;
  s.motor_level = Eigen::Vector4d::Constant(params.hover_level());
  return s;
}

// flatten: inline the RK4 stages and Eigen's small products (the step runs at 1 kHz; see ekf_bench).
[[gnu::flatten]] void Quadrotor::step(Seconds dt, const Eigen::Vector4d& motor_command,
                                      const Eigen::Vector3d& wind_N_m_s) {
  const double h = dt.count();
  REJUV_ASSERT(h > 0, "step needs dt > 0");
  const Eigen::Vector4d command = motor_command.cwiseMax(0.0).cwiseMin(1.0);

  // The rotor lag U̇ = (c − U)/τ is linear, so its exact solution U(t) = c + (U0 − c) e^{−t/τ} is evaluated at
  // the RK4 stages instead of integrating it (jMAVSim's Rotor does the same per step).
  const double tau = params_.motor_time_constant_s;
  const Eigen::Vector4d U0 = state_.motor_level;
  const double decay_half = tau > 0 ? std::exp(-0.5 * h / tau) : 0.0;  // e^{−h/2τ}; e^{−h/τ} is its square
  const Eigen::Vector4d U_half = command + (U0 - command) * decay_half;
  const Eigen::Vector4d U1 = command + (U0 - command) * (decay_half * decay_half);
  const Forcing f0 = forcing(mixer_, U0);
  const Forcing f_half = forcing(mixer_, U_half);
  const Forcing f1 = forcing(mixer_, U1);

  const Eigen::Matrix3d& I_inv = inertia_inv_B_;
  const Body x0 = pack(state_);
  const Body k1 = derivative(x0, f0, wind_N_m_s, params_, I_inv);
  const Body k2 = derivative(axpy(x0, 0.5 * h, k1), f_half, wind_N_m_s, params_, I_inv);
  const Body k3 = derivative(axpy(x0, 0.5 * h, k2), f_half, wind_N_m_s, params_, I_inv);
  const Body k4 = derivative(axpy(x0, h, k3), f1, wind_N_m_s, params_, I_inv);
  Body x1;
  for (std::size_t i = 0; i < x1.x.size(); ++i) {
    x1.x[i] = x0.x[i] + (h / 6.0) * (k1.x[i] + 2.0 * k2.x[i] + 2.0 * k3.x[i] + k4.x[i]);
  }

  const Eigen::Vector3d v_before = state_.v_NB_N;
  state_.p_NB_N = Eigen::Vector3d(x1.x[0], x1.x[1], x1.x[2]);
  state_.v_NB_N = Eigen::Vector3d(x1.x[3], x1.x[4], x1.x[5]);
  state_.q_NB = Eigen::Quaterniond(x1.x[6], x1.x[7], x1.x[8], x1.x[9]).normalized();
  state_.omega_B_rad_s = Eigen::Vector3d(x1.x[10], x1.x[11], x1.x[12]);
  state_.motor_level = U1;

  // Ground contact at z_N = 0 (NED: the ground is the plane z = 0, the air is z < 0).
  on_ground_ = false;
  if (state_.p_NB_N.z() >= 0.0) {
    state_.p_NB_N.z() = 0.0;
    state_.v_NB_N.z() = std::min(state_.v_NB_N.z(), 0.0);
    // Normal acceleration: what gravity and thrust press into the ground, m/s² (≥ 0 while resting).
    const Eigen::Vector3d thrust_N = state_.q_NB * Eigen::Vector3d(0, 0, -f1.thrust_N);
    const double normal_m_s2 = params_.gravity_m_s2 + thrust_N.z() / params_.mass_kg;
    if (normal_m_s2 >= 0.0) {
      on_ground_ = true;
      // Coulomb friction on the horizontal velocity; the landing gear stops the vehicle from rotating.
      Eigen::Vector2d v_xy = state_.v_NB_N.head<2>();
      const double speed = v_xy.norm();
      const double slowdown = params_.ground_friction * normal_m_s2 * h;
      v_xy = speed <= slowdown ? Eigen::Vector2d::Zero() : Eigen::Vector2d(v_xy * (1.0 - slowdown / speed));
      state_.v_NB_N.head<2>() = v_xy;
      state_.omega_B_rad_s.setZero();
    }
  }
  a_NB_N_ = (state_.v_NB_N - v_before) / h;
}

}  // namespace rejuv::plant
