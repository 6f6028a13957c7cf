// CpuWait (kernel_sim/kernel/src/cpu_wait.hpp): a wait past its deadline goes on while the processes that owe
// the answer are runnable and have not had the deadline's length of CPU, within max_cpu_wait of its
// beginning; on wall times and sights given by the test (no clock is read, no process started).
#include <gtest/gtest.h>

#include "cpu_wait.hpp"

namespace rejuv::kernel {
namespace {

using std::chrono::milliseconds;

constexpr Nanos kLength = milliseconds{100};  // the real-time resume deadline's

// A wait that began at 0 with its deadline at 100 ms.
CpuWait wait_from_zero() { return CpuWait(kLength, kLength, Nanos{0}); }

TEST(CpuWait, MaxCpuWait_TenDeadlinesAtLeastASecond) {
  EXPECT_EQ(max_cpu_wait(milliseconds{30}), std::chrono::seconds{1});
  EXPECT_EQ(max_cpu_wait(milliseconds{200}), std::chrono::seconds{2});
}

// Runnable with no CPU since the deadline: the wait goes on, one look at a time, and says so once.
TEST(CpuWait, RunnableWithoutCpu_GoesOnOneLookAtATime_FirstOnlyOnce) {
  CpuWait wait = wait_from_zero();
  EXPECT_FALSE(wait.went_on());
  const auto first = wait.go_on(milliseconds{100}, CpuSight{.ran = milliseconds{40}, .runnable = true});
  ASSERT_TRUE(first);
  EXPECT_TRUE(wait.went_on());
  EXPECT_EQ(first->until, milliseconds{100} + CpuWait::kLook);
  EXPECT_EQ(first->ran, Nanos{0});
  EXPECT_TRUE(first->first);
  const auto again = wait.go_on(milliseconds{110}, CpuSight{.ran = milliseconds{41}, .runnable = true});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->ran, milliseconds{1});
  EXPECT_FALSE(again->first);
}

// Stopped, asleep or blocked (not runnable), or unknown: the verdict is due at the deadline.
TEST(CpuWait, NotRunnableOrUnknown_VerdictAtTheDeadline) {
  CpuWait stopped = wait_from_zero();
  EXPECT_FALSE(stopped.go_on(milliseconds{100}, CpuSight{.ran = milliseconds{40}, .runnable = false}));
  // A verdict is no going on: the first time the wait does go on is still its first.
  const auto resumed = stopped.go_on(milliseconds{105}, CpuSight{.ran = milliseconds{40}, .runnable = true});
  ASSERT_TRUE(resumed);
  EXPECT_TRUE(resumed->first);
  CpuWait unknown = wait_from_zero();
  EXPECT_FALSE(unknown.go_on(milliseconds{100}, std::nullopt));
  EXPECT_FALSE(unknown.went_on()) << "a verdict is no going on";
  // Spared once, then stopped: judged then.
  CpuWait later = wait_from_zero();
  ASSERT_TRUE(later.go_on(milliseconds{100}, CpuSight{.ran = milliseconds{40}, .runnable = true}));
  EXPECT_FALSE(later.go_on(milliseconds{110}, CpuSight{.ran = milliseconds{40}, .runnable = false}));
}

// A process that had the deadline's length of CPU since the deadline and did not answer is not starved (it
// spins).
TEST(CpuWait, HadItsLengthOfCpu_VerdictDue) {
  CpuWait wait = wait_from_zero();
  ASSERT_TRUE(wait.go_on(milliseconds{100}, CpuSight{.ran = milliseconds{40}, .runnable = true}));
  EXPECT_TRUE(wait.go_on(milliseconds{200}, CpuSight{.ran = milliseconds{140}, .runnable = true}));
  EXPECT_FALSE(wait.go_on(milliseconds{210}, CpuSight{.ran = milliseconds{141}, .runnable = true}));
}

// Starved for max_cpu_wait since the wait began: judged; the last look ends at that limit, not past it.
TEST(CpuWait, StarvedPastMaxCpuWait_VerdictDue_LooksEndAtTheLimit) {
  CpuWait wait = wait_from_zero();
  const auto near = wait.go_on(milliseconds{995}, CpuSight{.ran = milliseconds{0}, .runnable = true});
  ASSERT_TRUE(near);
  EXPECT_EQ(near->until, std::chrono::seconds{1});
  EXPECT_FALSE(wait.go_on(std::chrono::seconds{1}, CpuSight{.ran = milliseconds{0}, .runnable = true}));
}

// Its CPU time known when the wait began (a Sync's): counted from then, not from the first look past the
// deadline — a process that had its length of CPU before the deadline and did not answer is not starved.
TEST(CpuWait, CpuTimeKnownAtTheBeginning_CountedFromThen) {
  CpuWait wait(kLength, kLength, Nanos{0}, milliseconds{40});
  const auto starved = wait.go_on(milliseconds{100}, CpuSight{.ran = milliseconds{45}, .runnable = true});
  ASSERT_TRUE(starved);
  EXPECT_EQ(starved->ran, milliseconds{5});
  CpuWait spun(kLength, kLength, Nanos{0}, milliseconds{40});
  EXPECT_FALSE(spun.go_on(milliseconds{100}, CpuSight{.ran = milliseconds{141}, .runnable = true}));
}

// A deadline later than the limit (a fallback's own resume deadline): the limit is never before it.
TEST(CpuWait, DeadlineAfterTheLimit_LimitIsTheDeadline) {
  CpuWait late(milliseconds{1500}, kLength, Nanos{0});
  EXPECT_FALSE(late.go_on(milliseconds{1500}, CpuSight{.ran = milliseconds{0}, .runnable = true}));
  EXPECT_EQ(late.deadline_at(), milliseconds{1500});
}

}  // namespace
}  // namespace rejuv::kernel
