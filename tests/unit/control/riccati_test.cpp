// DARE and discrete Lyapunov solvers (docs/design.md §9): residuals are checked, bad input is refused as a value.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight/riccati.hpp"

namespace rejuv::flight {
namespace {

DiscreteModel hover_model() {
  auto d = discretise_zoh(hover_linearisation(VehicleParams{}), Seconds{0.004});
  EXPECT_TRUE(d.has_value());
  return *d;
}

TEST(Riccati, Dare_HoverModel_ResidualSmall) {
  const DiscreteModel m = hover_model();
  const Eigen::MatrixXd Q = StateVec::Constant(10.0).asDiagonal();
  const Eigen::MatrixXd R = InputVec(1.0, 1e4, 1e4, 1e4).asDiagonal();
  const auto sol = solve_dare(m.A, m.B, Q, R);
  ASSERT_TRUE(sol.has_value()) << sol.error().message;
  EXPECT_LT(dare_residual(m.A, m.B, Q, R, sol->X), 1e-9);
  EXPECT_LT(sol->residual, 1e-9);
  // X is the cost-to-go: symmetric positive definite.
  EXPECT_TRUE(sol->X.isApprox(sol->X.transpose(), 1e-12));
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(sol->X).eigenvalues().minCoeff(), 0.0);
}

TEST(Riccati, Dare_ScalarCase_MatchesClosedForm) {
  // x+ = a x + b u: X solves X = a²X − a²b²X²/(r + b²X) + q. For a = 1, b = 1, q = 1, r = 1: X = (1 + √5)/2.
  const Eigen::MatrixXd one = Eigen::MatrixXd::Ones(1, 1);
  const auto sol = solve_dare(one, one, one, one);
  ASSERT_TRUE(sol.has_value());
  EXPECT_NEAR(sol->X(0, 0), (1.0 + std::sqrt(5.0)) / 2.0, 1e-12);
}

TEST(Riccati, Dare_NotStabilisable_ReturnsError) {
  // x+ = 2 x with no input authority: no stabilising solution exists.
  const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(2, 2) * 2.0;
  const Eigen::MatrixXd B = Eigen::MatrixXd::Zero(2, 1);
  const auto sol = solve_dare(A, B, Eigen::MatrixXd::Identity(2, 2), Eigen::MatrixXd::Ones(1, 1));
  ASSERT_FALSE(sol.has_value());
  EXPECT_TRUE(sol.error().kind == RiccatiError::NotConverged || sol.error().kind == RiccatiError::NotFinite)
      << to_string(sol.error().kind);
}

TEST(Riccati, Dare_BadDimensions_ReturnsBadDimensions) {
  const auto sol = solve_dare(Eigen::MatrixXd::Identity(3, 3), Eigen::MatrixXd::Ones(2, 1),
                              Eigen::MatrixXd::Identity(3, 3), Eigen::MatrixXd::Ones(1, 1));
  ASSERT_FALSE(sol.has_value());
  EXPECT_EQ(sol.error().kind, RiccatiError::BadDimensions);
}

TEST(Riccati, Dare_RNotPositive_ReturnsSingular) {
  const Eigen::MatrixXd one = Eigen::MatrixXd::Ones(1, 1);
  const auto sol = solve_dare(one, one, one, Eigen::MatrixXd::Zero(1, 1));
  ASSERT_FALSE(sol.has_value());
  EXPECT_EQ(sol.error().kind, RiccatiError::Singular);
}

TEST(Riccati, Dare_NanInput_ReturnsNotFinite) {
  const Eigen::MatrixXd one = Eigen::MatrixXd::Ones(1, 1);
  Eigen::MatrixXd q = one;
  q(0, 0) = std::numeric_limits<double>::quiet_NaN();
  const auto sol = solve_dare(one, one, q, one);
  ASSERT_FALSE(sol.has_value());
  EXPECT_EQ(sol.error().kind, RiccatiError::NotFinite);
}

TEST(Riccati, Lyapunov_StableMatrix_ResidualSmall) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Random(6, 6);
  A *= 0.9 / spectral_radius(A);
  const Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(6, 6);
  const auto sol = solve_discrete_lyapunov(A, Q);
  ASSERT_TRUE(sol.has_value()) << sol.error().message;
  EXPECT_LT((A.transpose() * sol->P * A - sol->P + Q).norm(), 1e-9);
}

TEST(Riccati, Lyapunov_UnstableMatrix_ReturnsNotStable) {
  const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(2, 2) * 1.01;
  const auto sol = solve_discrete_lyapunov(A, Eigen::MatrixXd::Identity(2, 2));
  ASSERT_FALSE(sol.has_value());
  EXPECT_EQ(sol.error().kind, RiccatiError::NotStable);
}

TEST(Riccati, Lyapunov_BadDimensions_ReturnsBadDimensions) {
  const auto sol = solve_discrete_lyapunov(Eigen::MatrixXd::Identity(2, 2) * 0.5, Eigen::MatrixXd::Identity(3, 3));
  ASSERT_FALSE(sol.has_value());
  EXPECT_EQ(sol.error().kind, RiccatiError::BadDimensions);
}

}  // namespace
}  // namespace rejuv::flight
