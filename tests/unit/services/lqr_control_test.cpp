// lqr_control: the simulation's mission LQR on messages; its controls never leave Ū.
#include <gtest/gtest.h>

#include <chrono>
#include <random>

#include "default_design_fixture.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/services/lqr_control/mission_control.hpp"
#include "service_test_messages.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;
using testing::state_message;

class MissionControlTest : public testing::DefaultDesignTest {
 protected:
  void SetUp() override {
    ASSERT_TRUE(design_.has_value());
    control_.emplace(*design_);
  }

  std::optional<MissionControl> control_;
};

TEST_F(MissionControlTest, MissionControl_NoSetpointYet_PublishesNothing) {
  const auto u = control_->on_state(state_message(flight::StateVec::Zero(), milliseconds{4}), Epoch{0});
  ASSERT_TRUE(u);
  EXPECT_FALSE(u->has_value());
}

TEST_F(MissionControlTest, MissionControl_InitialSetpoint_UsedUntilTheFirstMessage) {
  const flight::StateVec start = flight::hover_setpoint({0, 0, -3}, 0);
  MissionControl control(*design_, start);
  flight::StateVec x = start;
  x[2] += 0.2;  // 0.2 m low
  const auto u = control.on_state(state_message(x, milliseconds{4}), Epoch{0});
  ASSERT_TRUE(u && u->has_value());
  EXPECT_GT((*u)->thrust_N, design_->u_hover[0]) << "climbs back to the first waypoint";
  ASSERT_TRUE(control.on_setpoint(flight_io::setpoint_message(x, Nanos{0}, 1, false)));
  const auto v = control.on_state(state_message(x, milliseconds{8}), Epoch{0});
  ASSERT_TRUE(v && v->has_value());
  EXPECT_NEAR((*v)->thrust_N, design_->u_hover[0], 1e-9) << "at the new setpoint";
}

TEST_F(MissionControlTest, MissionControl_AtTheSetpoint_HoverThrustStampedWithTheEstimate) {
  const flight::StateVec x_sp = flight::hover_setpoint({1, 0, -3}, 0);
  ASSERT_TRUE(control_->on_setpoint(flight_io::setpoint_message(x_sp, Nanos{0}, 1, false)));
  const auto u = control_->on_state(state_message(x_sp, milliseconds{8}), Epoch{3});
  ASSERT_TRUE(u && u->has_value());
  const auto decoded = flight_io::controls_from_message(**u);
  ASSERT_TRUE(decoded);
  EXPECT_TRUE(decoded->isApprox(design_->u_hover, 1e-12));
  EXPECT_EQ((*u)->timestamp_ns, 8'000'000U);
  EXPECT_EQ((*u)->epoch, 3U);
}

TEST_F(MissionControlTest, MissionControl_AnyState_ControlsStayWithinTheRestrictedLimits) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 0, -3}, 0);
  ASSERT_TRUE(control_->on_setpoint(flight_io::setpoint_message(x_sp, Nanos{0}, 1, false)));
  std::mt19937_64 rng(42);
  std::normal_distribution<double> n(0.0, 1.0);
  int saturated = 0;
  for (int i = 0; i < 500; ++i) {
    flight::StateVec x = x_sp;
    for (Eigen::Index j = 0; j < flight::kStateDim; ++j) x[j] += 0.5 * n(rng);
    x.segment<3>(flight::idx::kAtt) = x.segment<3>(flight::idx::kAtt).cwiseMax(-1.2).cwiseMin(1.2);
    const auto u = control_->on_state(state_message(x, milliseconds{4}), Epoch{0});
    ASSERT_TRUE(u && u->has_value());
    const auto decoded = flight_io::controls_from_message(**u);
    ASSERT_TRUE(decoded);
    EXPECT_TRUE(design_->restricted.contains(*decoded, 1e-12)) << decoded->transpose();
    if (!design_->restricted.contains(design_->mission.unclamped(
            *flight_io::state_from_message(state_message(x, milliseconds{4})), x_sp))) {
      ++saturated;
    }
  }
  EXPECT_GT(saturated, 0) << "the test must include states where the linear law exceeds Ū";
}

TEST_F(MissionControlTest, MissionControl_SameInputs_SameControlsAsTheSimulationsMissionLqr) {
  const flight::StateVec x_sp = flight::hover_setpoint({0.4, 0.1, -3}, 0.05);
  ASSERT_TRUE(control_->on_setpoint(flight_io::setpoint_message(x_sp, Nanos{0}, 1, false)));
  flight::StateVec x = x_sp;
  x << 0.3, 0.2, -2.9, 0.1, -0.1, 0.05, 0.02, -0.03, 0.1, 0.1, 0.0, -0.2;
  const rejuv_msg_VehicleStateEstimate m = state_message(x, milliseconds{4});
  const auto u = control_->on_state(m, Epoch{0});
  ASSERT_TRUE(u && u->has_value());
  const flight::InputVec expected = design_->mission.control(*flight_io::state_from_message(m), x_sp);
  EXPECT_EQ(*flight_io::controls_from_message(**u), expected);
}

TEST_F(MissionControlTest, MissionControl_NonFiniteSetpoint_RefusedAndThePreviousKept) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 0, -3}, 0);
  ASSERT_TRUE(control_->on_setpoint(flight_io::setpoint_message(x_sp, Nanos{0}, 1, false)));
  rejuv_msg_Setpoint bad = flight_io::setpoint_message(x_sp, Nanos{0}, 1, false);
  bad.p_N_m[2] = std::numeric_limits<double>::quiet_NaN();
  const auto r = control_->on_setpoint(bad);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, flight_io::InputError::NotFinite);
  ASSERT_TRUE(control_->setpoint().has_value());
  EXPECT_EQ(*control_->setpoint(), x_sp);
}

#if defined(REJUV_ATTACK_HOOKS)
TEST_F(MissionControlTest, MissionControl_AttackHook_ReplacesTheHonestControls) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 0, -3}, 0);
  ASSERT_TRUE(control_->on_setpoint(flight_io::setpoint_message(x_sp, Nanos{0}, 1, false)));
  const flight::InputVec forged = design_->restricted.hi;
  control_->set_attack_hook([&](const flight::StateVec&, const flight::StateVec&, const flight::InputVec&) {
    return std::optional<flight::InputVec>(forged);
  });
  const auto u = control_->on_state(state_message(x_sp, milliseconds{4}), Epoch{0});
  ASSERT_TRUE(u && u->has_value());
  EXPECT_EQ(*flight_io::controls_from_message(**u), forged);
}
#endif

}  // namespace
}  // namespace rejuv::services
