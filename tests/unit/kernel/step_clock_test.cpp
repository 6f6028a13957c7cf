// The kernel's clocks as owners of their state (kernel_sim/kernel/src): KernelClock, the time page's one
// writer, seen by a service's reader; StepClock, the lockstep step queue with its sample count, rounds and
// deadlines (docs/design.md §6).
#include <gtest/gtest.h>

#include "kernel_clock.hpp"
#include "step_clock.hpp"

namespace rejuv::kernel {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

TEST(KernelClock, EveryChange_IsSeenByAServiceReader) {
  auto page = clock::TimePageWriter::create();
  ASSERT_TRUE(page.has_value()) << page.error().to_string();
  KernelClock k(std::move(*page), SrMode::MC);
  auto reader = clock::TimePageReader::map(k.read_only_fd().get());
  ASSERT_TRUE(reader.has_value()) << reader.error().to_string();
  EXPECT_EQ(reader->read().now, Nanos{0});
  EXPECT_EQ(reader->read().mode, SrMode::MC);
  EXPECT_EQ(reader->read().epoch, Epoch{0});
  k.advance(milliseconds{40});
  k.show_mode(SrMode::RB);
  k.begin_epoch();
  const clock::TimeSample s = reader->read();
  EXPECT_EQ(s.now, milliseconds{40});
  EXPECT_EQ(s.mode, SrMode::RB);  // begin_epoch keeps the mode; show_mode keeps the epoch
  EXPECT_EQ(s.epoch, Epoch{1});
  EXPECT_EQ(k.next_epoch(), Epoch{2});
}

TEST(StepClock, AStepBegins_OnlyOnceItsSamplesAreIn) {
  StepClock c;
  ASSERT_TRUE(c.offer(PendingStep{.step = 7, .t = milliseconds{4}, .samples_needed = 3}).has_value());
  c.count_samples(2);
  EXPECT_TRUE(c.short_of_samples());
  EXPECT_FALSE(c.begin_next(Nanos{0}).has_value());
  c.count_samples(1);
  EXPECT_FALSE(c.short_of_samples());
  const auto s = c.begin_next(milliseconds{10});
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->step, 7U);
  EXPECT_EQ(c.active()->t, milliseconds{4});
  EXPECT_FALSE(c.begin_next(milliseconds{10}).has_value()) << "one active step at a time";
}

// A second plant on the kernel's DDS domain: its SimSteps restart at 1 and t = 4 ms while this plant's are at
// step 500. Each must follow the last offered, or it is refused and not queued.
TEST(StepClock, AStepThatDoesNotFollowTheLast_IsRefusedAndNotQueued) {
  StepClock c;
  ASSERT_TRUE(c.offer(PendingStep{.step = 499, .t = milliseconds{1996}, .samples_needed = 0}).has_value());
  ASSERT_TRUE(c.offer(PendingStep{.step = 500, .t = milliseconds{2000}, .samples_needed = 0}).has_value());
  const auto other_plant = c.offer(PendingStep{.step = 1, .t = milliseconds{4}, .samples_needed = 0});
  ASSERT_FALSE(other_plant.has_value());
  EXPECT_NE(other_plant.error().find("step 1 at t = 4000000 ns does not follow step 500"), std::string::npos)
      << other_plant.error();
  EXPECT_FALSE(c.offer(PendingStep{.step = 500, .t = milliseconds{2000}, .samples_needed = 0}).has_value())
      << "a step offered twice";
  EXPECT_FALSE(c.offer(PendingStep{.step = 501, .t = milliseconds{2000}, .samples_needed = 0}).has_value())
      << "the next number at the same time";
  EXPECT_FALSE(c.offer(PendingStep{.step = 502, .t = milliseconds{2008}, .samples_needed = 0}).has_value())
      << "a step skipped";
  std::vector<std::uint64_t> queued;
  while (const auto s = c.begin_next(Nanos{0})) {
    queued.push_back(s->step);
    c.finish(Nanos{0});
  }
  EXPECT_EQ(queued, (std::vector<std::uint64_t>{499, 500})) << "only the steps that followed were queued";
  EXPECT_TRUE(c.offer(PendingStep{.step = 501, .t = milliseconds{2004}, .samples_needed = 0}).has_value())
      << "the plant's own next step is still taken";
}

TEST(StepClock, MissingSamples_GivenUpAfterPatience_AndTheCountResynchronised) {
  StepClock c;
  ASSERT_TRUE(c.offer(PendingStep{.step = 1, .t = milliseconds{4}, .samples_needed = 5}).has_value());
  ASSERT_TRUE(c.offer(PendingStep{.step = 2, .t = milliseconds{8}, .samples_needed = 9}).has_value());
  c.count_samples(3);
  EXPECT_FALSE(c.give_up_on_samples(seconds{10}, seconds{1}).has_value());  // the wait starts here
  EXPECT_FALSE(c.give_up_on_samples(seconds{11}, seconds{1}).has_value());  // not longer than the patience
  const auto gave_up = c.give_up_on_samples(seconds{11} + milliseconds{1}, seconds{1});
  ASSERT_TRUE(gave_up.has_value());
  EXPECT_EQ(gave_up->step, 1U);
  EXPECT_EQ(gave_up->missing, 2U);
  ASSERT_TRUE(c.begin_next(seconds{12}).has_value());
  c.finish(seconds{12});
  c.count_samples(4);  // the next step's four: counted from the re-synchronised 5
  ASSERT_TRUE(c.begin_next(seconds{12}).has_value());
}

TEST(StepClock, Deadlines_IdleWhileActive_StallOncePerStall) {
  StepClock c;
  EXPECT_FALSE(c.stall_deadline().has_value()) << "no stall before the first step completes";
  c.offer_manual(milliseconds{4});
  ASSERT_TRUE(c.begin_next(seconds{1}).has_value());
  EXPECT_EQ(c.idle_deadline(seconds{2}), seconds{3});
  c.restart_idle_deadline(seconds{5});
  EXPECT_EQ(c.idle_deadline(seconds{2}), seconds{7});
  c.note_hung(ServiceId{3});
  EXPECT_EQ(c.hung().size(), 1U);
  c.finish(seconds{6});
  EXPECT_EQ(c.steps_done(), 1U);
  EXPECT_FALSE(c.idle_deadline(seconds{2}).has_value());
  EXPECT_EQ(c.stall_deadline(), seconds{6} + kStallReportAfter);
  c.stall_reported();
  EXPECT_FALSE(c.stall_deadline().has_value()) << "reported once per stall";
  c.note_hung(ServiceId{4});  // between steps: not a step's hung service
  c.offer_manual(milliseconds{8});
  ASSERT_TRUE(c.begin_next(seconds{20}).has_value());
  EXPECT_TRUE(c.hung().empty());
  c.finish(seconds{21});
  EXPECT_EQ(c.stall_deadline(), seconds{21} + kStallReportAfter) << "a completed step re-arms the report";
}

TEST(StepClock, Rounds_CountedPerStepAndCut) {
  StepClock c;
  c.offer_manual(milliseconds{4});
  ASSERT_TRUE(c.begin_next(Nanos{0}).has_value());
  for (std::uint32_t i = 0; i < kMaxRoundsPerStep; ++i) {
    EXPECT_FALSE(c.rounds_exhausted());
    c.next_round();
  }
  EXPECT_TRUE(c.rounds_exhausted());
  c.finish(Nanos{1});
  c.offer_manual(milliseconds{8});
  ASSERT_TRUE(c.begin_next(Nanos{1}).has_value());
  EXPECT_EQ(c.rounds(), 0U);
  EXPECT_EQ(c.active()->step, 1U) << "manual steps are numbered in order";
}

}  // namespace
}  // namespace rejuv::kernel
