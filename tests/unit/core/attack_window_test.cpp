// The one window rule of the launch plan's attacks (rejuv/core/attack_window.hpp): when a window begins is
// tested through the runtime hooks' WindowClock (tests/security/attack_plan_test.cpp); here, when it is open.
#include <gtest/gtest.h>

#include "rejuv/core/attack_window.hpp"

namespace rejuv {
namespace {

using namespace std::chrono_literals;

TEST(AttackWindowClock, OpenFromItsBeginUntilTheModeOrEpochChanges) {
  AttackWindowClock c(AttackSchedule{.start = 0ns, .max_windows = 1});
  EXPECT_FALSE(c.begins(0ms, SrMode::SC, Epoch{0}));
  EXPECT_FALSE(c.open(SrMode::SC, Epoch{0}));
  EXPECT_TRUE(c.begins(10ms, SrMode::MC, Epoch{0}));
  EXPECT_TRUE(c.open(SrMode::MC, Epoch{0}));
  EXPECT_FALSE(c.open(SrMode::RB, Epoch{1})) << "the rollback ends it";
  EXPECT_FALSE(c.begins(30ms, SrMode::MC, Epoch{1})) << "max_windows";
  EXPECT_FALSE(c.open(SrMode::MC, Epoch{1}));
}

TEST(AttackWindowClock, SecureIntervalKind_OpenInTheSecureIntervalOnly) {
  AttackWindowClock c(AttackSchedule{.start = 0ns, .window = AttackWindowKind::SecureInterval});
  EXPECT_TRUE(c.begins(0ms, SrMode::SC, Epoch{0}));
  EXPECT_TRUE(c.open(SrMode::CP, Epoch{0}));
  EXPECT_FALSE(c.open(SrMode::MC, Epoch{0}));
}

TEST(AttackWindowClock, SrOff_OpenForeverOnceBegun) {
  AttackWindowClock c(AttackSchedule{.start = 5ms, .sr = Rejuvenation::Off});
  EXPECT_FALSE(c.begins(1ms, SrMode::MC, Epoch{0}));
  EXPECT_FALSE(c.open(SrMode::MC, Epoch{0}));
  EXPECT_TRUE(c.begins(6ms, SrMode::MC, Epoch{0}));
  EXPECT_TRUE(c.open(SrMode::MC, Epoch{0}));
}

}  // namespace
}  // namespace rejuv
