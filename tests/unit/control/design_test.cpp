// The full control design (docs/design.md §9): both LQRs stabilise the discrete hover model, P > 0 and its scaled
// ellipsoid touches the state box, Ū is a motor-feasible box around hover inside U.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "rejuv/flight/control_design.hpp"

namespace rejuv::flight {
namespace {

const ControlDesign& design() {
  static const ControlDesign d = [] {
    auto r = design_control(ControlDesignSpec{});
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
    return *r;
  }();
  return d;
}

double max_abs_eigenvalue(const StateMat& A) {
  return Eigen::EigenSolver<StateMat>(A, false).eigenvalues().cwiseAbs().maxCoeff();
}

TEST(ControlDesign, MissionLqr_DefaultDesign_DareResidualSmall) {
  EXPECT_LT(design().mission.dare_residual(), 1e-9);
  EXPECT_LT(dare_residual(design().discrete.A, design().discrete.B,
                          StateMat(design().mission_weights.q_diag.asDiagonal()),
                          Eigen::Matrix4d(design().mission_weights.r_diag.asDiagonal()),
                          design().mission.riccati_X()),
            1e-9);
}

TEST(ControlDesign, SafetyLqr_DefaultDesign_DareResidualSmall) { EXPECT_LT(design().safety.dare_residual(), 1e-9); }

TEST(ControlDesign, MissionLqr_ClosedLoop_EigenvaluesInsideUnitCircle) {
  EXPECT_LT(max_abs_eigenvalue(design().mission.closed_loop()), 1.0);
}

TEST(ControlDesign, SafetyLqr_ClosedLoop_EigenvaluesInsideUnitCircle) {
  EXPECT_LT(max_abs_eigenvalue(design().safety.closed_loop()), 1.0);
}

TEST(ControlDesign, SafetyLqr_ComparedToMission_ConvergesFaster) {
  // The safety controller must win back the state quickly after an attack; the mission one may be gentle.
  EXPECT_LT(max_abs_eigenvalue(design().safety.closed_loop()), max_abs_eigenvalue(design().mission.closed_loop()));
}

TEST(ControlDesign, Ellipsoid_DefaultDesign_PPositiveDefinite) {
  const auto eig = Eigen::SelfAdjointEigenSolver<StateMat>(design().ellipsoid.P()).eigenvalues();
  EXPECT_GT(eig.minCoeff(), 0.0);
  EXPECT_TRUE(design().ellipsoid.P().isApprox(design().ellipsoid.P().transpose(), 1e-12));
}

TEST(ControlDesign, Ellipsoid_Scaled_TouchesBox) {
  const StateVec b = StateBox{}.half_widths();
  const StateMat P_inv = design().ellipsoid.P().inverse();
  const double ratio = (P_inv.diagonal().array() / b.array().square()).maxCoeff();
  EXPECT_NEAR(ratio, 1.0, 1e-9);
  EXPECT_TRUE(((design().ellipsoid.semi_axes_along_coordinates().array() - b.array()) <= 1e-9).all());
}

TEST(ControlDesign, Ellipsoid_FittedToBox_TouchesMostFaces) {
  // The fitted Lyapunov weight stretches E(1) to the box wherever the loop allows: all horizontal axes, the
  // tilt, the yaw and the roll/pitch rates; only the vertical position (tied to vz by the stiff altitude loop)
  // and the yaw rate stay inside.
  const StateVec ratio = design().ellipsoid.semi_axes_along_coordinates().cwiseQuotient(StateBox{}.half_widths());
  EXPECT_GE((ratio.array() >= 0.98).count(), 10);
  EXPECT_LE(ratio.maxCoeff(), 1.0 + 1e-9);
}

TEST(ControlDesign, Ellipsoid_BoundaryPoints_InsideBox) {
  // Every point with V = 1 lies in the box: |e_i| ≤ b_i.
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const StateVec b = StateBox{}.half_widths();
  for (int k = 0; k < 2000; ++k) {
    StateVec e;
    for (auto& v : e) v = n(rng);
    e /= std::sqrt(design().ellipsoid.V(e));
    EXPECT_TRUE(((e.cwiseAbs() - b).array() <= 1e-9).all());
  }
}

TEST(ControlDesign, Ellipsoid_SafetyClosedLoop_VDecreases) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 500; ++k) {
    StateVec e;
    for (auto& v : e) v = n(rng);
    const StateVec next = design().safety.closed_loop() * e;
    EXPECT_LT(design().ellipsoid.V(next), design().ellipsoid.V(e));
  }
}

TEST(ControlDesign, Ellipsoid_BadBox_ReturnsBadBox) {
  StateBox box;
  box.rate_rad_s = 0.0;
  const auto r = SafetyEllipsoid::from_closed_loop(design().safety.closed_loop(), StateMat::Identity(), box);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, EllipsoidError::BadBox);
}

TEST(ControlDesign, Ellipsoid_UnstableLoop_ReturnsLyapunovError) {
  // The open-loop hover model has eigenvalues at 1: no Lyapunov P.
  const auto r = SafetyEllipsoid::from_closed_loop(design().discrete.A, StateMat::Identity(), StateBox{});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, EllipsoidError::Lyapunov);
}

TEST(ControlDesign, Ellipsoid_IndefiniteMatrix_ReturnsNotPositiveDefinite) {
  StateMat P = StateMat::Identity();
  P(3, 3) = -1.0;
  const auto r = SafetyEllipsoid::from_matrix(P);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, EllipsoidError::NotPositiveDefinite);
}

TEST(ControlDesign, Limits_Restricted_InsideFullAroundHover) {
  const ControlDesign& d = design();
  EXPECT_TRUE(d.restricted.contains(d.u_hover));
  EXPECT_TRUE(d.full.contains(d.restricted.lo));
  EXPECT_TRUE(d.full.contains(d.restricted.hi));
  EXPECT_TRUE(((d.restricted.hi - d.restricted.lo).array() < (d.full.hi - d.full.lo).array()).all());
}

TEST(ControlDesign, Limits_FractionOutOfRange_ReturnsBadFraction) {
  const auto r = restricted_limits(VehicleParams{}, 0.0);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LimitsError::BadFraction);
}

TEST(ControlDesign, Limits_WholeRange_ReturnsNotMotorFeasible) {
  // Full thrust and full roll torque at once would need a rotor above 100 %.
  const auto r = restricted_limits(VehicleParams{}, 1.0);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LimitsError::NotMotorFeasible);
}

TEST(ControlDesign, MissionLqr_Control_ClampedToRestrictedLimits) {
  const ControlDesign& d = design();
  const StateVec x_hat = hover_setpoint(Eigen::Vector3d(5.0, -5.0, 2.0), 1.0);
  const InputVec u = d.mission.control(x_hat, hover_setpoint(Eigen::Vector3d::Zero(), 0.0));
  EXPECT_TRUE(d.restricted.contains(u, 1e-12));
  EXPECT_FALSE(d.restricted.contains(d.mission.unclamped(x_hat, hover_setpoint(Eigen::Vector3d::Zero(), 0.0))));
}

TEST(ControlDesign, Design_BadControlPeriod_ReturnsModelError) {
  ControlDesignSpec spec;
  spec.control_period = Seconds{-0.001};
  const auto r = design_control(spec);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, DesignError::Model);
}

}  // namespace
}  // namespace rejuv::flight
