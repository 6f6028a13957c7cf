// Hover model, discretisation and angle helpers (docs/design.md §9).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "rejuv/flight/hover_model.hpp"

namespace rejuv::flight {
namespace {

TEST(HoverModel, HoverModel_Linearisation_TiltAcceleratesSideways) {
  const LinearModel m = hover_linearisation(VehicleParams{});
  // Pitch up (θ > 0) tips the thrust backwards (−x); roll right (φ > 0) pushes to +y (east).
  EXPECT_LT(m.A(idx::kVel + 0, idx::kAtt + 1), 0.0);
  EXPECT_GT(m.A(idx::kVel + 1, idx::kAtt + 0), 0.0);
  // More thrust accelerates up, which is −z in NED.
  EXPECT_LT(m.B(idx::kVel + 2, idx::kThrust), 0.0);
}

TEST(HoverModel, Discretise_HoverModel_MatchesAnalyticDoubleIntegrator) {
  const VehicleParams params;
  const auto d = discretise_zoh(hover_linearisation(params), Seconds{0.004});
  ASSERT_TRUE(d.has_value());
  const double T = 0.004;
  // z'' = −δF/m under a held input: Δz = −T²/(2m) δF, Δv = −T/m δF.
  EXPECT_NEAR(d->B(idx::kPos + 2, idx::kThrust), -T * T / (2.0 * params.mass_kg), 1e-15);
  EXPECT_NEAR(d->B(idx::kVel + 2, idx::kThrust), -T / params.mass_kg, 1e-15);
  // Roll torque reaches y position through 4 integrators: Δy = g T⁴/(24 Jxx) τφ.
  EXPECT_NEAR(d->B(idx::kPos + 1, 1), params.gravity_m_s2 * std::pow(T, 4) / (24.0 * 0.005), 1e-15);
}

TEST(HoverModel, Discretise_NonPositivePeriod_ReturnsBadParameter) {
  const auto d = discretise_zoh(hover_linearisation(VehicleParams{}), Seconds{0.0});
  ASSERT_FALSE(d.has_value());
  EXPECT_EQ(d.error().kind, ModelError::BadParameter);
}

TEST(HoverModel, Validate_CannotLift_ReturnsBadParameter) {
  VehicleParams p;
  p.mass_kg = 2.0;  // 4 k1 = 16 N < 19.6 N
  const auto v = validate(p);
  ASSERT_FALSE(v.has_value());
  EXPECT_EQ(v.error().kind, ModelError::BadParameter);
}

TEST(HoverModel, Validate_NegativeInertia_ReturnsBadParameter) {
  VehicleParams p;
  p.inertia_diag_kg_m2.y() = -1.0;
  EXPECT_FALSE(validate(p).has_value());
}

TEST(HoverModel, WrapAngle_LargeAngles_FoldIntoHalfOpenInterval) {
  EXPECT_NEAR(wrap_angle_rad(3.0 * std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(-std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(0.1 + 4.0 * std::numbers::pi), 0.1, 1e-12);
}

TEST(HoverModel, EulerFromQuaternion_ZyxRotation_RoundTrips) {
  const double roll = 0.2, pitch = -0.3, yaw = 2.5;
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  const Eigen::Vector3d e = euler_from_quaternion(q);
  EXPECT_NEAR(e.x(), roll, 1e-12);
  EXPECT_NEAR(e.y(), pitch, 1e-12);
  EXPECT_NEAR(e.z(), yaw, 1e-12);
}

TEST(HoverModel, StateError_YawAcrossPi_Wrapped) {
  const StateVec a = hover_setpoint(Eigen::Vector3d::Zero(), 3.1);
  const StateVec b = hover_setpoint(Eigen::Vector3d::Zero(), -3.1);
  EXPECT_NEAR(state_error(a, b)[idx::kYaw], 6.2 - 2.0 * std::numbers::pi, 1e-12);
}

}  // namespace
}  // namespace rejuv::flight
