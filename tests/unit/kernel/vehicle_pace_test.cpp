// VehiclePace (kernel_sim/kernel/src/vehicle_pace.hpp): where in the vehicle's control period a checkpoint may
// start and when a rejuvenation timer fires early, on wall times given by the test (no clock is read).
#include <gtest/gtest.h>

#include "vehicle_pace.hpp"

namespace rejuv::kernel {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

constexpr Nanos kPeriod = milliseconds{4};

// A pace that has seen `updates` control updates kPeriod apart, the last at `last`.
VehiclePace paced(Nanos last, int updates = 5) {
  VehiclePace pace(true);
  for (int i = updates - 1; i >= 0; --i) pace.on_control_update(last - i * kPeriod);
  return pace;
}

TEST(VehiclePace, Disabled_AlwaysStartsAndNeverFiresEarly) {
  VehiclePace pace(false);
  for (int i = 0; i < 5; ++i) pace.on_control_update(i * kPeriod);
  EXPECT_FALSE(pace.period().has_value());
  EXPECT_TRUE(pace.may_start(milliseconds{19}));
  EXPECT_FALSE(pace.fire_early(milliseconds{16}, microseconds{100}));
  EXPECT_FALSE(pace.wait_deadline().has_value());
}

TEST(VehiclePace, Period_IsTheMedianSoOneLateUpdateDoesNotMoveIt) {
  VehiclePace pace(true);
  EXPECT_FALSE(pace.period().has_value());
  pace.on_control_update(milliseconds{0});
  pace.on_control_update(milliseconds{4});
  pace.on_control_update(milliseconds{8});
  EXPECT_FALSE(pace.period().has_value()) << "two intervals are not a period yet";
  pace.on_control_update(milliseconds{17});  // a late one (9 ms)
  pace.on_control_update(milliseconds{21});
  ASSERT_TRUE(pace.period().has_value());
  EXPECT_EQ(*pace.period(), kPeriod);
}

TEST(VehiclePace, Period_IgnoresStallsAndDoubleUpdates) {
  VehiclePace pace = paced(milliseconds{100});
  pace.on_control_update(milliseconds{100} + microseconds{10});  // two updates of one sample
  pace.on_control_update(milliseconds{900});                     // a stall
  EXPECT_EQ(*pace.period(), kPeriod);
}

TEST(VehiclePace, WithoutAPeriodYet_StartsAtOnce) {
  VehiclePace pace(true);
  pace.on_control_update(milliseconds{0});
  EXPECT_TRUE(pace.may_start(milliseconds{3}));
}

TEST(VehiclePace, Checkpoint_StartsInTheFirstHalfOfThePeriod) {
  const VehiclePace pace = paced(milliseconds{100});
  EXPECT_TRUE(pace.in_slack(milliseconds{100}));
  EXPECT_TRUE(pace.in_slack(milliseconds{102}));
  EXPECT_FALSE(pace.in_slack(milliseconds{102} + microseconds{1}));
  EXPECT_FALSE(pace.in_slack(milliseconds{103} + microseconds{900}));
}

TEST(VehiclePace, Checkpoint_LateInThePeriodWaitsForTheNextUpdate) {
  VehiclePace pace = paced(milliseconds{100});
  EXPECT_FALSE(pace.may_start(milliseconds{103}));
  ASSERT_TRUE(pace.wait_deadline().has_value());
  EXPECT_EQ(*pace.wait_deadline(), milliseconds{103} + VehiclePace::kMaxWaitPeriods * kPeriod);
  pace.on_control_update(milliseconds{104});
  EXPECT_TRUE(pace.may_start(milliseconds{104} + microseconds{50}));
  pace.started();
  EXPECT_FALSE(pace.wait_deadline().has_value());
}

TEST(VehiclePace, Checkpoint_AChainThatStoppedUpdatingDelaysItAtMostTheBound) {
  VehiclePace pace = paced(milliseconds{100});
  EXPECT_FALSE(pace.may_start(milliseconds{103}));
  EXPECT_FALSE(pace.may_start(milliseconds{110}));
  EXPECT_TRUE(pace.may_start(milliseconds{111}));
}

TEST(VehiclePace, Timer_DueBeforeTheNextUpdateFiresInThisSlack) {
  const VehiclePace pace = paced(milliseconds{100});
  // At 100.1 ms: the next update is expected at 104 ms.
  const Nanos now = milliseconds{100} + microseconds{100};
  EXPECT_TRUE(pace.fire_early(now, milliseconds{3}));
  EXPECT_FALSE(pace.fire_early(now, milliseconds{4})) << "due after the next update: that slack is its own";
  EXPECT_FALSE(pace.fire_early(now, Nanos{0})) << "already due: it fires anyway, not early";
  EXPECT_FALSE(pace.fire_early(milliseconds{103}, microseconds{500})) << "outside the slack";
}

}  // namespace
}  // namespace rejuv::kernel
