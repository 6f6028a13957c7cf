// Mission path and the setpoint update of §IV-A: x̂ stays in E(ρ_M, x_sp'), x_sp moves monotonically along
// the path, and never moves when x̂ is outside E(ρ_M, x_sp).
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight/setpoint.hpp"

namespace rejuv::flight {
namespace {

constexpr double kRhoM = 0.1;

std::shared_ptr<const WaypointPath> square_path() {
  auto p = WaypointPath::make({{{0, 0, -3}, 0}, {{1, 0, -3}, 0}, {{1, 1, -3}, 0}, {{0, 1, -3}, 0}, {{0, 0, -3}, 0}});
  EXPECT_TRUE(p.has_value());
  return std::make_shared<const WaypointPath>(*p);
}

class SetpointTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto r = design_control(ControlDesignSpec{});
    ASSERT_TRUE(r.has_value()) << r.error().to_string();
    d_ = std::make_unique<ControlDesign>(*r);
  }
  [[nodiscard]] const SafetyEllipsoid& P() const { return d_->ellipsoid; }
  std::unique_ptr<ControlDesign> d_;
};

TEST(WaypointPath, WaypointPath_NoWaypoints_ReturnsEmpty) {
  const auto p = WaypointPath::make({});
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().kind, PathError::Empty);
}

TEST(WaypointPath, WaypointPath_NanWaypoint_ReturnsNotFinite) {
  const auto p = WaypointPath::make({{{0, 0, std::numeric_limits<double>::quiet_NaN()}, 0}});
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().kind, PathError::NotFinite);
}

TEST(WaypointPath, WaypointPath_DistanceTo_SquareSides) {
  const auto path = square_path();
  EXPECT_NEAR(path->distance_to({0.5, -0.2, -3}), 0.2, 1e-12);  // beside the first side
  EXPECT_NEAR(path->distance_to({0.5, 0.5, -3}), 0.5, 1e-12);   // centre of the square
  EXPECT_NEAR(path->distance_to({1.3, 1.4, -3}), 0.5, 1e-12);   // outside the corner (1, 1)
  EXPECT_NEAR(path->distance_to({0.5, 0.0, -2.9}), 0.1, 1e-12);  // below the path
  EXPECT_NEAR(path->length_m(), 4.0, 1e-12);
}

TEST_F(SetpointTest, Update_EstimateAtSetpoint_KeepsEstimateInRhoM) {
  SetpointGenerator gen(square_path());
  const StateVec x_hat = gen.setpoint();
  ASSERT_EQ(gen.update(x_hat, P(), kRhoM), UpdateOutcome::Moved);
  EXPECT_LE(P().norm(x_hat, gen.setpoint()), kRhoM);
  // As far as allowed: on the boundary of E(ρ_M, x_sp').
  EXPECT_NEAR(P().norm(x_hat, gen.setpoint()), kRhoM, 1e-6);
  EXPECT_GT(gen.setpoint().x(), 0.0);
}

TEST_F(SetpointTest, Update_RandomEstimatesInRhoS_KeepEstimateInRhoMAndMoveForward) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  SetpointGenerator gen(square_path());
  double last_progress = gen.cursor().progress();
  int moves = 0;
  for (int k = 0; k < 2000 && !gen.finished(); ++k) {
    // An estimate anywhere in E(0.0894, x_sp): a random direction scaled into the small ellipsoid.
    StateVec dir;
    for (auto& v : dir) v = n(rng);
    const double scale = 0.0894 * std::uniform_real_distribution<double>(0.0, 1.0)(rng) / std::sqrt(P().V(dir));
    const StateVec x_hat = gen.setpoint() + scale * dir;
    const UpdateOutcome out = gen.update(x_hat, P(), kRhoM);
    ASSERT_NE(out, UpdateOutcome::Held);
    EXPECT_LE(P().norm(x_hat, gen.setpoint()), kRhoM + 1e-12);
    EXPECT_GE(gen.cursor().progress(), last_progress);
    last_progress = gen.cursor().progress();
    moves += out == UpdateOutcome::Moved ? 1 : 0;
  }
  EXPECT_TRUE(gen.finished());
  EXPECT_GT(moves, 4);  // at least one update per side
  EXPECT_TRUE(gen.setpoint().segment<3>(idx::kPos).isApprox(Eigen::Vector3d(0, 0, -3)));
}

TEST_F(SetpointTest, Update_EstimateOutsideRhoM_Held) {
  SetpointGenerator gen(square_path());
  StateVec x_hat = gen.setpoint();
  x_hat[idx::kPos + 1] += 1.0;  // far to the side
  const StateVec before = gen.setpoint();
  EXPECT_EQ(gen.update(x_hat, P(), kRhoM), UpdateOutcome::Held);
  EXPECT_EQ(gen.setpoint(), before);
}

TEST_F(SetpointTest, Update_AtLastWaypoint_Finished) {
  auto one = WaypointPath::make({{{2, 3, -3}, 0}});
  ASSERT_TRUE(one.has_value());
  SetpointGenerator gen(std::make_shared<const WaypointPath>(*one));
  EXPECT_EQ(gen.update(gen.setpoint(), P(), kRhoM), UpdateOutcome::Moved);  // the degenerate segment completes
  EXPECT_TRUE(gen.finished());
  EXPECT_EQ(gen.update(gen.setpoint(), P(), kRhoM), UpdateOutcome::Finished);
}

TEST_F(SetpointTest, Update_NeverPassesAWaypoint_StopsAtCorner) {
  SetpointGenerator gen(square_path());
  for (int k = 0; k < 1000 && gen.cursor().segment == 0 && gen.cursor().tau < 1.0; ++k) {
    gen.update(gen.setpoint(), P(), kRhoM);
    EXPECT_NEAR(gen.setpoint().y(), 0.0, 1e-12);  // still on the first side
  }
  EXPECT_TRUE(gen.setpoint().segment<3>(idx::kPos).isApprox(Eigen::Vector3d(1, 0, -3)));
  EXPECT_EQ(gen.target_waypoint(), 1U);
}

}  // namespace
}  // namespace rejuv::flight
