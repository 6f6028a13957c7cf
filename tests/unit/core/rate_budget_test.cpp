// RateBudget (rejuv/core/rate_budget.hpp): the token bucket of the kernel's publication budget and the ULog's
// size budget, over a clock the test hands it.
#include "rejuv/core/rate_budget.hpp"

#include <gtest/gtest.h>

#include <chrono>

namespace rejuv {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

TEST(RateBudget, Fresh_PassesItsBurstAtOnceThenNothing) {
  RateBudget b(100, 10);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(b.take(Nanos{0})) << i;
  EXPECT_FALSE(b.take(Nanos{0}));
}

TEST(RateBudget, Empty_RefillsAtItsRate) {
  RateBudget b(100, 10);  // one unit per 10 ms
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(b.take(Nanos{0}));
  EXPECT_FALSE(b.take(milliseconds{9}));
  EXPECT_TRUE(b.take(milliseconds{10}));
  EXPECT_FALSE(b.take(milliseconds{10}));
  // Over a second: its rate, not more.
  int passed = 0;
  for (int ms = 11; ms <= 1010; ++ms) passed += b.take(milliseconds{ms}) ? 1 : 0;
  EXPECT_EQ(passed, 100);
}

TEST(RateBudget, LongIdle_RefillsNoMoreThanTheBurst) {
  RateBudget b(100, 10);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(b.take(Nanos{0}));
  int passed = 0;
  for (int i = 0; i < 50; ++i) passed += b.take(seconds{3600}) ? 1 : 0;
  EXPECT_EQ(passed, 10);
}

TEST(RateBudget, ClockBack_RefillsNothing) {
  RateBudget b(100, 10);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(b.take(seconds{5}));
  EXPECT_FALSE(b.take(seconds{4}));
  EXPECT_FALSE(b.take(seconds{5}));
}

TEST(RateBudget, Units_ChargedByWeight) {
  RateBudget b(1000, 5000);  // bytes: 1000 B/s, 5000 B of burst
  EXPECT_TRUE(b.take(Nanos{0}, 4000));
  EXPECT_FALSE(b.take(Nanos{0}, 1001));
  EXPECT_TRUE(b.take(Nanos{0}, 1000));
  EXPECT_TRUE(b.take(seconds{1}, 1000));
}

TEST(RateBudget, Refilled_SaysWhenHalfTheBurstIsBack) {
  RateBudget b(100, 10);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(b.take(Nanos{0}));
  EXPECT_FALSE(b.refilled(milliseconds{40}, 50));
  EXPECT_TRUE(b.refilled(milliseconds{50}, 50));
}

}  // namespace
}  // namespace rejuv
