// Quadrotor rigid body and mixer (docs/design.md §9, paper §IV-B).
#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/plant/wind.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace rejuv::plant {
namespace {

using namespace std::chrono_literals;

constexpr Seconds kDt{1e-3};  // the plant runs at 1 kHz

QuadParams no_drag() {
  QuadParams p = QuadParams::jmavsim_default();
  p.drag_coefficient_N_s_m = 0;
  return p;
}

// Total mechanical energy, J: translational + rotational kinetic, and potential with z down (PE = −m g z).
double energy_J(const QuadParams& p, const QuadState& s) {
  return 0.5 * p.mass_kg * s.v_NB_N.squaredNorm() +
         0.5 * s.omega_B_rad_s.dot(p.inertia_B_kg_m2 * s.omega_B_rad_s) -
         p.mass_kg * p.gravity_m_s2 * s.p_NB_N.z();
}

// Thrust force in N, N: the rotors push along −z_B.
Eigen::Vector3d thrust_N(const QuadParams& p, const QuadState& s) {
  return s.q_NB * Eigen::Vector3d(0, 0, -p.max_thrust_per_motor_N * s.motor_level.sum());
}

TEST(QuadParams, JmavsimDefault_HoverLevel_CarriesWeight) {
  const QuadParams p = QuadParams::jmavsim_default();
  EXPECT_NEAR(p.hover_level() * 4 * p.max_thrust_per_motor_N, p.mass_kg * p.gravity_m_s2, 1e-12);
  EXPECT_GT(p.hover_level(), 0.0);
  EXPECT_LT(p.hover_level(), 1.0);
}

TEST(Mixer, MatrixEntries_MatchPaperSectionIVB) {
  const QuadParams p = QuadParams::jmavsim_default();
  const double k1 = p.max_thrust_per_motor_N;
  const double k2 = p.max_torque_per_motor_N_m;
  const double L = p.arm_length_m;
  Eigen::Matrix4d expected;
  expected << k1, k1, k1, k1, 0, -L * k1, 0, L * k1, L * k1, 0, -L * k1, 0, -k2, k2, -k2, k2;
  EXPECT_TRUE(Mixer(p).matrix().isApprox(expected));
}

TEST(Mixer, InverseAfterForward_IsIdentity) {
  const Mixer mixer(QuadParams::jmavsim_default());
  EXPECT_TRUE((mixer.inverse() * mixer.matrix()).isApprox(Eigen::Matrix4d::Identity(), 1e-12));
  const Eigen::Vector4d U(0.1, 0.7, 0.35, 0.9);
  EXPECT_TRUE(mixer.motors_from_wrench(mixer.wrench_from_motors(U)).isApprox(U, 1e-12));
}

TEST(Mixer, ForwardAfterInverse_IsIdentity) {
  const Mixer mixer(QuadParams::jmavsim_default());
  EXPECT_TRUE((mixer.matrix() * mixer.inverse()).isApprox(Eigen::Matrix4d::Identity(), 1e-12));
  const Eigen::Vector4d u(7.0, 0.05, -0.08, 0.01);  // [F, τφ, τθ, τψ]
  EXPECT_TRUE(mixer.wrench_from_motors(mixer.motors_from_wrench(u)).isApprox(u, 1e-12));
}

TEST(Quadrotor, NoThrust_FallsAtGravity) {
  const QuadParams p = no_drag();
  QuadState s0 = Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -100));
  s0.motor_level.setZero();
  Quadrotor quad(p, s0);
  for (int i = 0; i < 1000; ++i) {
    quad.step(kDt, Eigen::Vector4d::Zero());
  }
  // After 1 s of free fall: v = g t down, z = z0 + g t²/2 (RK4 is exact for constant acceleration).
  EXPECT_NEAR(quad.state().v_NB_N.z(), p.gravity_m_s2, 1e-9);
  EXPECT_NEAR(quad.state().p_NB_N.z(), -100 + 0.5 * p.gravity_m_s2, 1e-9);
  EXPECT_NEAR(quad.state().v_NB_N.head<2>().norm(), 0.0, 1e-12);
  EXPECT_TRUE(quad.acceleration_N().isApprox(Eigen::Vector3d(0, 0, p.gravity_m_s2), 1e-9));
}

TEST(Quadrotor, HoverTrim_HoldsPositionFor10s) {
  const QuadParams p = QuadParams::jmavsim_default();
  const Eigen::Vector3d p0(1, -2, -3);
  Quadrotor quad(p, Quadrotor::hover_at(p, p0));
  const Eigen::Vector4d hover = Eigen::Vector4d::Constant(p.hover_level());
  for (int i = 0; i < 10'000; ++i) {
    quad.step(kDt, hover);
  }
  EXPECT_LT((quad.state().p_NB_N - p0).norm(), 1e-9);
  EXPECT_LT(quad.state().v_NB_N.norm(), 1e-9);
  EXPECT_LT(quad.state().omega_B_rad_s.norm(), 1e-12);
  EXPECT_FALSE(quad.on_ground());
}

TEST(Quadrotor, NoDrag_EnergyChangeEqualsThrustWork) {
  // Given a tilted, spinning vehicle with equal rotor commands (no torque) and no drag,
  const QuadParams p = no_drag();
  QuadState s0 = Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -50));
  s0.q_NB = Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 0.5, 0).normalized());
  s0.omega_B_rad_s = Eigen::Vector3d(0.3, -0.2, 1.0);
  Quadrotor quad(p, s0);
  const Eigen::Vector4d command = Eigen::Vector4d::Constant(0.6);
  // when it flies for 2 s, the thrust power F·v integrated (trapezoid at 1 kHz) is the work done on it,
  double work_J = 0;
  for (int i = 0; i < 2000; ++i) {
    const double power_before_W = thrust_N(p, quad.state()).dot(quad.state().v_NB_N);
    quad.step(kDt, command);
    const double power_after_W = thrust_N(p, quad.state()).dot(quad.state().v_NB_N);
    work_J += 0.5 * (power_before_W + power_after_W) * kDt.count();
  }
  // then ΔKE + ΔPE equals it.
  const double delta_energy_J = energy_J(p, quad.state()) - energy_J(p, s0);
  ASSERT_GT(std::abs(work_J), 1.0);  // the test exercises real work
  EXPECT_NEAR(delta_energy_J, work_J, 1e-4 * std::abs(work_J));
}

TEST(Quadrotor, MotorLag_Reaches63PercentAfterOneTimeConstant) {
  const QuadParams p = QuadParams::jmavsim_default();
  QuadState s0 = Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -10));
  s0.motor_level.setZero();
  Quadrotor quad(p, s0);
  const int steps = static_cast<int>(std::lround(p.motor_time_constant_s / kDt.count()));
  for (int i = 0; i < steps; ++i) {
    quad.step(kDt, Eigen::Vector4d::Ones());
  }
  const double expected = 1.0 - std::exp(-1.0);  // 0.632
  EXPECT_TRUE(quad.state().motor_level.isApprox(Eigen::Vector4d::Constant(expected), 1e-9));
}

TEST(Quadrotor, MotorCommand_ClampedToUnitInterval) {
  const QuadParams p = QuadParams::jmavsim_default();
  Quadrotor quad(p, Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -10)));
  for (int i = 0; i < 200; ++i) {
    quad.step(kDt, Eigen::Vector4d(2.0, -1.0, 5.0, -3.0));
  }
  EXPECT_TRUE(quad.state().motor_level.isApprox(Eigen::Vector4d(1, 0, 1, 0), 1e-9));
}

TEST(Quadrotor, LeftRotorFaster_RollsRight) {
  // τφ = L k1 (U4 − U2) (§IV-B): rotor 4 (left) faster than rotor 2 (right) rolls right wing down (+φ in
  // FRD).
  const QuadParams p = QuadParams::jmavsim_default();
  Quadrotor quad(p, Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -10)));
  const double h = p.hover_level();
  for (int i = 0; i < 50; ++i) {
    quad.step(kDt, Eigen::Vector4d(h, h - 0.05, h, h + 0.05));
  }
  EXPECT_GT(quad.state().omega_B_rad_s.x(), 0.1);
  EXPECT_NEAR(quad.state().omega_B_rad_s.y(), 0.0, 1e-9);
}

TEST(Quadrotor, DroppedOnGround_StopsAtZero) {
  const QuadParams p = QuadParams::jmavsim_default();
  QuadState s0 = Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -1));
  s0.motor_level.setZero();
  s0.v_NB_N = Eigen::Vector3d(1.0, 0.5, 0);  // sliding sideways when it lands
  Quadrotor quad(p, s0);
  double max_z = -1;
  for (int i = 0; i < 3000; ++i) {
    quad.step(kDt, Eigen::Vector4d::Zero());
    max_z = std::max(max_z, quad.state().p_NB_N.z());
  }
  EXPECT_LE(max_z, 0.0);
  EXPECT_EQ(quad.state().p_NB_N.z(), 0.0);
  EXPECT_LT(quad.state().v_NB_N.norm(), 1e-9);  // friction stopped the slide
  EXPECT_TRUE(quad.on_ground());
  EXPECT_LT(quad.acceleration_N().norm(), 1e-9);  // resting: the ground carries the weight
}

TEST(Quadrotor, OnGroundWithFullThrust_TakesOff) {
  const QuadParams p = QuadParams::jmavsim_default();
  QuadState s0 = Quadrotor::hover_at(p, Eigen::Vector3d::Zero());
  s0.motor_level.setZero();
  Quadrotor quad(p, s0);
  for (int i = 0; i < 500; ++i) {
    quad.step(kDt, Eigen::Vector4d::Constant(0.8));
  }
  EXPECT_LT(quad.state().p_NB_N.z(), -0.1);
  EXPECT_FALSE(quad.on_ground());
}

TEST(Quadrotor, TumblingFor10s_QuaternionStaysUnit) {
  const QuadParams p = QuadParams::jmavsim_default();
  QuadState s0 = Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -1000));
  s0.omega_B_rad_s = Eigen::Vector3d(3.0, -2.0, 5.0);
  Quadrotor quad(p, s0);
  double worst = 0;
  for (int i = 0; i < 10'000; ++i) {
    quad.step(kDt, Eigen::Vector4d(0.9, 0.2, 0.6, 0.4));
    worst = std::max(worst, std::abs(quad.state().q_NB.norm() - 1.0));
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_GT(quad.state().omega_B_rad_s.norm(), 1.0);  // it really tumbled
}

TEST(Quadrotor, Wind_DragPushesDownwind) {
  const QuadParams p = QuadParams::jmavsim_default();
  Quadrotor quad(p, Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -10)));
  const Eigen::Vector3d wind(5, 0, 0);
  for (int i = 0; i < 1000; ++i) {
    quad.step(kDt, Eigen::Vector4d::Constant(p.hover_level()), wind);
  }
  // Linear drag F = −c (v − w): at first a = c w / m, so after 1 s roughly half of c w t² / m.
  EXPECT_GT(quad.state().v_NB_N.x(), 0.0);
  EXPECT_NEAR(quad.state().p_NB_N.x(), 0.5 * p.drag_coefficient_N_s_m * 5.0 / p.mass_kg, 1e-3);
}

// plant.wind_toward_deg: clockwise from north, the direction the air moves to (a westerly, "from 270°", is 90).
TEST(Wind, MeanTowardDegrees_ClockwiseFromNorth) {
  EXPECT_TRUE(mean_wind_N(3, 0).isApprox(Eigen::Vector3d(3, 0, 0)));
  EXPECT_LT((mean_wind_N(3, 90) - Eigen::Vector3d(0, 3, 0)).norm(), 1e-12);
  EXPECT_LT((mean_wind_N(2, 225) - Eigen::Vector3d(-std::sqrt(2.0), -std::sqrt(2.0), 0)).norm(), 1e-12);
}

// The direction reaches the vehicle: a wind toward east pushes it east, not north.
TEST(Wind, TowardEast_DriftsTheVehicleEast) {
  const QuadParams p = QuadParams::jmavsim_default();
  Quadrotor quad(p, Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -10)));
  Wind wind(WindParams{.mean_N_m_s = mean_wind_N(5, 90)}, 1);
  for (int i = 0; i < 1000; ++i) {
    quad.step(kDt, Eigen::Vector4d::Constant(p.hover_level()), wind.step(kDt));
  }
  // As Wind_DragPushesDownwind, turned a quarter: about half of c w t² / m east after 1 s, none north.
  EXPECT_NEAR(quad.state().p_NB_N.y(), 0.5 * p.drag_coefficient_N_s_m * 5.0 / p.mass_kg, 1e-3);
  EXPECT_LT(std::abs(quad.state().p_NB_N.x()), 1e-6);
}

}  // namespace
}  // namespace rejuv::plant
