// safety_control: the simulation's safety LQR on messages, with the full limits U, warm in every mode.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <optional>
#include <random>

#include "rejuv/flight_io/params.hpp"
#include "rejuv/services/safety_control/safety_control.hpp"
#include "default_design_fixture.hpp"
#include "service_test_messages.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;
using testing::state_message;

class SafetyControlTest : public testing::DefaultDesignTest {};

TEST_F(SafetyControlTest, SafetyControl_NoSetpointYet_PublishesNothing) {
  SafetyControl control(*design_);
  const auto u = control.on_state(state_message(flight::StateVec::Zero(), milliseconds{4}), Epoch{0});
  ASSERT_TRUE(u);
  EXPECT_FALSE(u->has_value());
}

TEST_F(SafetyControlTest, SafetyControl_AtTheSetpoint_HoverThrustStampedWithTheEstimateAndEpoch) {
  const flight::StateVec x_sp = flight::hover_setpoint({1, 0, -3}, 0);
  SafetyControl control(*design_, x_sp);
  const auto u = control.on_state(state_message(x_sp, milliseconds{8}), Epoch{5});
  ASSERT_TRUE(u && u->has_value());
  const auto decoded = flight_io::controls_from_message(**u);
  ASSERT_TRUE(decoded);
  EXPECT_TRUE(decoded->isApprox(design_->u_hover, 1e-12));
  EXPECT_EQ((*u)->timestamp_ns, 8'000'000U);
  EXPECT_EQ((*u)->epoch, 5U);
}

TEST_F(SafetyControlTest, SafetyControl_AnyState_IsTheSimulationsSafetyLaw) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 1, -3}, 0.3);
  SafetyControl control(*design_, x_sp);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 0.2);
  for (int i = 0; i < 50; ++i) {
    flight::StateVec x = x_sp;
    for (int k = 0; k < flight::kStateDim; ++k) x[k] += n(rng);
    const auto message = state_message(x, milliseconds{4 * (i + 1)});
    const auto u = control.on_state(message, Epoch{0});
    ASSERT_TRUE(u && u->has_value());
    const auto x_hat = flight_io::state_from_message(message);
    ASSERT_TRUE(x_hat);
    const auto decoded = flight_io::controls_from_message(**u);
    ASSERT_TRUE(decoded);
    EXPECT_EQ(*decoded, design_->safety.control(*x_hat, x_sp))
        << "step " << i << ": the same numbers expected";
  }
}

TEST_F(SafetyControlTest, SafetyControl_LargeError_UsesTheFullLimitsBeyondTheRestrictedOnes) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 0, -3}, 0);
  SafetyControl control(*design_, x_sp);
  flight::StateVec x = x_sp;
  x[2] += 0.5;  // 0.5 m low (NED)
  const auto u = control.on_state(state_message(x, milliseconds{4}), Epoch{0});
  ASSERT_TRUE(u && u->has_value());
  const auto decoded = flight_io::controls_from_message(**u);
  ASSERT_TRUE(decoded);
  EXPECT_GT((*decoded)[0], design_->restricted.hi[0]) << "climbs harder than Ū would allow";
  EXPECT_TRUE(design_->full.contains(*decoded, 1e-12)) << "but within U";
}

TEST_F(SafetyControlTest, SafetyControl_SetpointWhileSilent_TheFirstControlsUseTheLatestOne) {
  // Warm: in MC it is not published, but it keeps the latest x_sp and x̂ for the moment it takes over.
  SafetyControl control(*design_, flight::hover_setpoint({0, 0, -3}, 0));
  const flight::StateVec moved = flight::hover_setpoint({0.1, 0, -3}, 0);
  ASSERT_TRUE(control.on_setpoint(flight_io::setpoint_message(moved, milliseconds{2}, 1, false)));
  const auto u = control.on_state(state_message(moved, milliseconds{4}), Epoch{1});
  ASSERT_TRUE(u && u->has_value());
  const auto decoded = flight_io::controls_from_message(**u);
  ASSERT_TRUE(decoded);
  EXPECT_TRUE(decoded->isApprox(design_->u_hover, 1e-12)) << "at the new setpoint: hover, no transient";
  ASSERT_TRUE(control.estimate().has_value());
  EXPECT_TRUE(control.estimate()->isApprox(moved, 1e-12));
}

TEST_F(SafetyControlTest, SafetyControl_NonFiniteState_RefusedAndNothingPublished) {
  SafetyControl control(*design_, flight::hover_setpoint({0, 0, -3}, 0));
  flight::StateVec x = flight::hover_setpoint({0, 0, -3}, 0);
  auto m = state_message(x, milliseconds{4});
  m.v_N_m_s[1] = std::numeric_limits<double>::quiet_NaN();
  const auto u = control.on_state(m, Epoch{0});
  ASSERT_FALSE(u);
  EXPECT_EQ(u.error().kind, flight_io::InputError::NotFinite);
  EXPECT_FALSE(control.estimate().has_value());
}

TEST_F(SafetyControlTest, SafetyControl_NonFiniteSetpoint_RefusedAndThePreviousKept) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 0, -3}, 0);
  SafetyControl control(*design_, x_sp);
  auto m = flight_io::setpoint_message(flight::hover_setpoint({1, 0, -3}, 0), milliseconds{2}, 1, false);
  m.p_N_m[0] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(control.on_setpoint(m));
  ASSERT_TRUE(control.setpoint().has_value());
  EXPECT_EQ(*control.setpoint(), x_sp);
}

}  // namespace
}  // namespace rejuv::services
