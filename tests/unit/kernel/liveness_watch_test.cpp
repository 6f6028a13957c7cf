// LivenessWatch (kernel_sim/kernel/src/liveness_watch.hpp): who is asked for an Idle and who is hung in real time,
// on wall times and sights given by the test (no clock is read, no process started).
#include <gtest/gtest.h>

#include "liveness_watch.hpp"

namespace rejuv::kernel {
namespace {

using std::chrono::milliseconds;
using Kind = LivenessCall::Kind;

constexpr Nanos kChainDeadline = milliseconds{30};
constexpr Nanos kOtherDeadline = milliseconds{200};

LivenessSight sight(bool chain, pid_t pid, std::uint64_t frames_in, std::uint64_t frames_out,
                    std::uint64_t reported, bool watched = true) {
  return LivenessSight{.id = ServiceId{3}, .watched = watched, .chain = chain, .pid = pid, .frames_in = frames_in,
                       .frames_out = frames_out, .reported = reported};
}

TEST(LivenessWatch, Passes_AtMostOneEveryChainLook) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  EXPECT_TRUE(watch.begin_pass(milliseconds{1000}));
  EXPECT_FALSE(watch.begin_pass(milliseconds{1005}));
  EXPECT_TRUE(watch.begin_pass(milliseconds{1010}));
}

TEST(LivenessWatch, ChainServiceThatKeepsSpeaking_IsNeverAsked) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  for (int i = 0; i < 100; ++i) {
    // It sends a frame between looks and 5 frames sent to it are always unreported (in flight).
    const LivenessCall call = watch.look(sight(true, 42, 10 + i, 20 + i, 15 + i), milliseconds{10 * i});
    EXPECT_EQ(call.kind, Kind::Nothing) << "look " << i;
  }
}

TEST(LivenessWatch, SilentChainService_AskedThenHungAfterTheChainDeadline) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = sight(true, 42, 10, 20, 15);
  EXPECT_EQ(watch.look(silent, milliseconds{0}).kind, Kind::Nothing) << "the first look only notes it";
  EXPECT_EQ(watch.look(silent, milliseconds{5}).kind, Kind::Nothing) << "before kChainLook";
  const LivenessCall ask = watch.look(silent, milliseconds{10});
  ASSERT_EQ(ask.kind, Kind::Ask);
  EXPECT_EQ(ask.owed, 20u) << "its Idle must report every frame sent to it";
  watch.asked(silent.id, milliseconds{10}, ask.owed);
  EXPECT_EQ(watch.look(silent, milliseconds{20}).kind, Kind::Nothing);
  EXPECT_EQ(watch.look(silent, milliseconds{40}).kind, Kind::Nothing) << "exactly at the deadline: not yet";
  const LivenessCall overdue = watch.look(silent, milliseconds{50});
  ASSERT_EQ(overdue.kind, Kind::Overdue);
  EXPECT_EQ(overdue.owed, 20u);
  EXPECT_EQ(overdue.deadline, kChainDeadline);
}

TEST(LivenessWatch, SilentServiceWithNothingOwed_IsNotAsked) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight idle = sight(true, 42, 10, 20, 20);  // every frame sent to it reported: idle, not hung
  for (int i = 0; i < 50; ++i) EXPECT_EQ(watch.look(idle, milliseconds{10 * i}).kind, Kind::Nothing);
}

TEST(LivenessWatch, ServiceOffTheChain_LookedAtEveryLookWithTheOthersDeadline) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = sight(false, 7, 3, 9, 4);
  EXPECT_EQ(watch.look(silent, milliseconds{0}).kind, Kind::Nothing);
  EXPECT_EQ(watch.look(silent, milliseconds{50}).kind, Kind::Nothing) << "before kLook";
  const LivenessCall ask = watch.look(silent, milliseconds{100});
  ASSERT_EQ(ask.kind, Kind::Ask);
  watch.asked(silent.id, milliseconds{100}, ask.owed);
  EXPECT_EQ(watch.look(silent, milliseconds{200}).kind, Kind::Nothing);
  EXPECT_EQ(watch.look(silent, milliseconds{300}).kind, Kind::Nothing) << "200 ms after the Sync: not over";
  const LivenessCall overdue = watch.look(silent, milliseconds{400});
  ASSERT_EQ(overdue.kind, Kind::Overdue);
  EXPECT_EQ(overdue.deadline, kOtherDeadline);
  EXPECT_EQ(overdue.owed, 9u);
}

TEST(LivenessWatch, AnswerOrNewIncarnationAfterTheSync_IsNotHung) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = sight(true, 42, 10, 20, 15);
  (void)watch.look(silent, milliseconds{0});
  watch.asked(silent.id, milliseconds{10}, watch.look(silent, milliseconds{10}).owed);
  // Its Idle arrived (a frame in): alive, looked at afresh.
  EXPECT_EQ(watch.look(sight(true, 42, 11, 20, 20), milliseconds{50}).kind, Kind::Nothing);
  EXPECT_EQ(watch.look(sight(true, 42, 11, 20, 20), milliseconds{100}).kind, Kind::Nothing);

  LivenessWatch rolled(kChainDeadline, kOtherDeadline);
  (void)rolled.look(silent, milliseconds{0});
  rolled.asked(silent.id, milliseconds{10}, rolled.look(silent, milliseconds{10}).owed);
  // A rollback restored another incarnation (same counts): not the one that was asked.
  EXPECT_EQ(rolled.look(sight(true, 43, 10, 20, 15), milliseconds{50}).kind, Kind::Nothing);
}

TEST(LivenessWatch, UnwatchedService_ForgetsTheSync) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = sight(true, 42, 10, 20, 15);
  (void)watch.look(silent, milliseconds{0});
  watch.asked(silent.id, milliseconds{10}, watch.look(silent, milliseconds{10}).owed);
  // It replays the catch-up (not watched) past the deadline, then is watched again.
  EXPECT_EQ(watch.look(sight(true, 42, 10, 20, 15, false), milliseconds{50}).kind, Kind::Nothing);
  EXPECT_EQ(watch.look(silent, milliseconds{55}).kind, Kind::Nothing) << "noted afresh at 50 ms";
  EXPECT_EQ(watch.look(silent, milliseconds{60}).kind, Kind::Ask) << "asked again, not overdue";
}

TEST(LivenessWatch, AfterAnOverdue_FreshStartsTheWatchAgain) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = sight(true, 42, 10, 20, 15);
  (void)watch.look(silent, milliseconds{0});
  watch.asked(silent.id, milliseconds{10}, watch.look(silent, milliseconds{10}).owed);
  ASSERT_EQ(watch.look(silent, milliseconds{50}).kind, Kind::Overdue);
  watch.fresh(silent, milliseconds{50});  // its Idle was in the channel after all
  EXPECT_EQ(watch.look(silent, milliseconds{55}).kind, Kind::Nothing);
  EXPECT_EQ(watch.look(silent, milliseconds{60}).kind, Kind::Ask);
}

TEST(LivenessWatch, Services_AreWatchedApart) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  LivenessSight a = sight(true, 42, 10, 20, 15);
  LivenessSight b = sight(true, 50, 1, 2, 2);
  b.id = ServiceId{9};  // beyond a: the watch grows
  (void)watch.look(a, milliseconds{0});
  (void)watch.look(b, milliseconds{0});
  EXPECT_EQ(watch.look(a, milliseconds{10}).kind, Kind::Ask);
  EXPECT_EQ(watch.look(b, milliseconds{10}).kind, Kind::Nothing) << "b owes nothing";
}

// A silent chain service looked at first at 0 ms and sent a Sync at 10 ms, the scheduler having given it `cpu`
// until then (nullopt: unknown).
LivenessSight asked_at_10ms(LivenessWatch& watch, std::optional<CpuSight> cpu) {
  const LivenessSight silent = sight(true, 42, 10, 20, 15);
  (void)watch.look(silent, milliseconds{0});
  watch.asked(silent.id, milliseconds{10}, watch.look(silent, milliseconds{10}).owed, cpu);
  return silent;
}

// A service still runnable when its deadline is over is judged by the CPU time it had since the Sync: waiting for
// a CPU is spared; once it has had its deadline's worth of CPU without answering, it is hung.
TEST(LivenessWatch, RunnableServiceWaitingForACpu_SparedUntilItHadItsDeadlineOfCpu) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = asked_at_10ms(watch, CpuSight{.ran = milliseconds{500}, .runnable = true});
  ASSERT_EQ(watch.look(silent, milliseconds{50}).kind, Kind::Overdue);
  // 40 ms since the Sync, 5 ms of them on a CPU, runnable: waiting for one.
  const auto spared = watch.spared_for_cpu(silent.id, milliseconds{50}, CpuSight{milliseconds{505}, true}, kChainDeadline);
  ASSERT_TRUE(spared.has_value());
  EXPECT_EQ(spared->ran, milliseconds{5});
  EXPECT_EQ(spared->since, milliseconds{40});
  EXPECT_TRUE(spared->first) << "the first spare of this Sync: said once";
  ASSERT_EQ(watch.look(silent, milliseconds{60}).kind, Kind::Overdue);
  const auto again = watch.spared_for_cpu(silent.id, milliseconds{60}, CpuSight{milliseconds{520}, true}, kChainDeadline);
  ASSERT_TRUE(again.has_value());
  EXPECT_FALSE(again->first);
  // Then it had 31 ms of CPU without answering: it spins.
  ASSERT_EQ(watch.look(silent, milliseconds{90}).kind, Kind::Overdue);
  EXPECT_FALSE(watch.spared_for_cpu(silent.id, milliseconds{90}, CpuSight{milliseconds{531}, true}, kChainDeadline))
      << "31 ms of CPU since the Sync: over the 30 ms deadline";
}

// A service stopped (SIGSTOP), blocked or asleep with the Sync unanswered is not waiting for a CPU: the deadline
// holds as it is, however little CPU it had.
TEST(LivenessWatch, ServiceNotRunnable_HungAtItsDeadline) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = asked_at_10ms(watch, CpuSight{.ran = milliseconds{500}, .runnable = true});
  ASSERT_EQ(watch.look(silent, milliseconds{50}).kind, Kind::Overdue);
  EXPECT_FALSE(watch.spared_for_cpu(silent.id, milliseconds{50}, CpuSight{milliseconds{500}, false}, kChainDeadline));
}

// Starved for longer than max_cpu_wait: judged (a service the machine does not run is lost to the vehicle).
TEST(LivenessWatch, ServiceStarvedPastTheBound_Hung) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  EXPECT_EQ(max_cpu_wait(kChainDeadline), std::chrono::seconds{1});
  EXPECT_EQ(max_cpu_wait(kOtherDeadline), std::chrono::seconds{2});
  const LivenessSight silent = asked_at_10ms(watch, CpuSight{milliseconds{0}, true});
  ASSERT_EQ(watch.look(silent, milliseconds{1000}).kind, Kind::Overdue);
  EXPECT_TRUE(watch.spared_for_cpu(silent.id, milliseconds{1000}, CpuSight{milliseconds{2}, true}, kChainDeadline))
      << "990 ms since the Sync, 2 ms of CPU";
  ASSERT_EQ(watch.look(silent, milliseconds{1020}).kind, Kind::Overdue);
  EXPECT_FALSE(watch.spared_for_cpu(silent.id, milliseconds{1020}, CpuSight{milliseconds{2}, true}, kChainDeadline))
      << "1010 ms since the Sync: past the bound however little CPU it had";
}

// Where its CPU time is unknown (at the Sync or now), the deadline holds as it is.
TEST(LivenessWatch, CpuTimeUnknown_HungAtItsDeadline) {
  LivenessWatch watch(kChainDeadline, kOtherDeadline);
  const LivenessSight silent = asked_at_10ms(watch, std::nullopt);  // unknown at the Sync
  ASSERT_EQ(watch.look(silent, milliseconds{50}).kind, Kind::Overdue);
  EXPECT_FALSE(watch.spared_for_cpu(silent.id, milliseconds{50}, CpuSight{milliseconds{0}, true}, kChainDeadline));
  LivenessWatch now_unknown(kChainDeadline, kOtherDeadline);
  (void)asked_at_10ms(now_unknown, CpuSight{milliseconds{0}, true});
  ASSERT_EQ(now_unknown.look(silent, milliseconds{50}).kind, Kind::Overdue);
  EXPECT_FALSE(now_unknown.spared_for_cpu(silent.id, milliseconds{50}, std::nullopt, kChainDeadline));
}

}  // namespace
}  // namespace rejuv::kernel
