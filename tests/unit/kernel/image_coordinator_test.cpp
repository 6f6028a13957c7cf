// The image coordinator's state as one owner (image_coordinator.hpp, docs/design.md §7): the checkpoint's
// None → Asked → Running → None, the rollback asked once with its first reason, the alignment's checkpoint once
// per run, the abandoned checkpoint's owed answers, the image work left behind and the rejuvenation timer's
// once-per-epoch arm. Illegal transitions break the invariant (death tests).
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "image_coordinator.hpp"

namespace rejuv::kernel {
namespace {

using std::chrono::milliseconds;
using Checkpoint = ImageCoordinator::Checkpoint;

TEST(ImageCoordinator, Checkpoint_AskedBeginsRunsAndEnds_WithTheCallersSeq) {
  ImageCoordinator c;
  EXPECT_EQ(c.checkpoint(), Checkpoint::None);
  EXPECT_EQ(c.running(), nullptr);
  ASSERT_TRUE(c.ask_checkpoint(ServiceId{3}, 41));
  EXPECT_EQ(c.checkpoint(), Checkpoint::Asked);
  EXPECT_TRUE(c.asked());
  EXPECT_EQ(c.asked_by(), ServiceId{3});
  EXPECT_EQ(c.running(), nullptr) << "asked is not running";

  CheckpointRun& run = c.begin_checkpoint(Generation{7}, Nanos{123});
  EXPECT_EQ(c.checkpoint(), Checkpoint::Running);
  EXPECT_FALSE(c.asked()) << "a running checkpoint no longer waits for its safe point";
  EXPECT_EQ(c.running(), &run);
  EXPECT_EQ(run.caller, ServiceId{3});
  EXPECT_EQ(run.seq, 41U);
  EXPECT_FALSE(run.priming);
  EXPECT_EQ(run.record.g, Generation{7});
  EXPECT_EQ(run.t_cp, Nanos{123});
  run.waiting.push_back(ServiceId{1});
  run.failure = "why";

  const CheckpointRun done = c.end_checkpoint();
  EXPECT_EQ(c.checkpoint(), Checkpoint::None);
  EXPECT_EQ(c.running(), nullptr);
  EXPECT_EQ(done.record.g, Generation{7});
  EXPECT_EQ(done.waiting, std::vector<ServiceId>{ServiceId{1}});
  EXPECT_EQ(done.failure, "why");

  ASSERT_TRUE(c.ask_checkpoint(std::nullopt, 0)) << "the next one may be asked once the last has ended";
  EXPECT_EQ(c.begin_checkpoint(Generation{8}, Nanos{0}).failure, "") << "a run starts with nothing of the last";
}

TEST(ImageCoordinator, Checkpoint_OneAtATime_AskedOrRunningRefusesAnother) {
  ImageCoordinator c;
  ASSERT_TRUE(c.ask_checkpoint(ServiceId{1}, 1));
  EXPECT_FALSE(c.ask_checkpoint(ServiceId{2}, 2));
  EXPECT_EQ(c.asked_by(), ServiceId{1}) << "the refused ask changed nothing";
  (void)c.begin_checkpoint(Generation{1}, Nanos{0});
  EXPECT_FALSE(c.ask_checkpoint(ServiceId{2}, 2)) << "refused while running";
  EXPECT_EQ(c.running()->caller, ServiceId{1});
}

TEST(ImageCoordinator, VoidAsk_TheAskGoes_AndAnotherMayBeAsked) {
  ImageCoordinator c;
  ASSERT_TRUE(c.ask_checkpoint(ServiceId{4}, 9));
  c.void_ask();
  EXPECT_EQ(c.checkpoint(), Checkpoint::None);
  EXPECT_FALSE(c.asked());
  ASSERT_TRUE(c.ask_checkpoint(std::nullopt, 0));
  EXPECT_EQ(c.asked_by(), std::nullopt) << "the kernel's own ask carries no caller of the voided one";
}

TEST(ImageCoordinator, Priming_OncePerRun_AndNotWhileSomethingIsAsked) {
  ImageCoordinator c;
  c.ask_rollback("lost");
  EXPECT_FALSE(c.ask_priming()) << "a rollback is asked";
  (void)c.take_rollback();
  ASSERT_TRUE(c.ask_checkpoint(ServiceId{1}, 1));
  EXPECT_FALSE(c.ask_priming()) << "a checkpoint is asked";
  c.void_ask();

  ASSERT_TRUE(c.ask_priming());
  EXPECT_EQ(c.asked_by(), std::nullopt);
  CheckpointRun& run = c.begin_checkpoint(Generation{1}, Nanos{0});
  EXPECT_TRUE(run.priming);
  (void)c.end_checkpoint();
  EXPECT_FALSE(c.ask_priming()) << "once per run";
  ASSERT_TRUE(c.ask_checkpoint(std::nullopt, 0));
  EXPECT_FALSE(c.begin_checkpoint(Generation{2}, Nanos{0}).priming) << "later checkpoints are timed";
}

TEST(ImageCoordinator, Rollback_TheFirstReasonKept_TakenOnce) {
  ImageCoordinator c;
  EXPECT_FALSE(c.rollback_asked());
  c.ask_rollback("the rejuvenation timer fired");
  c.ask_rollback("'ekf2' was lost");
  EXPECT_TRUE(c.rollback_asked());
  EXPECT_TRUE(c.asked());
  EXPECT_EQ(c.take_rollback(), "the rejuvenation timer fired");
  EXPECT_FALSE(c.rollback_asked());
  EXPECT_FALSE(c.asked());
  c.ask_rollback("again");
  c.drop_rollback();
  EXPECT_FALSE(c.rollback_asked()) << "a cold restart drops it";
}

TEST(ImageCoordinator, RollbackAskedWhileACheckpointRuns_BothStandUntilEach_Ends) {
  ImageCoordinator c;
  ASSERT_TRUE(c.ask_checkpoint(ServiceId{1}, 1));
  (void)c.begin_checkpoint(Generation{5}, Nanos{0});
  c.ask_rollback("'sensors' was lost during the checkpoint");
  EXPECT_EQ(c.checkpoint(), Checkpoint::Running);
  EXPECT_TRUE(c.rollback_asked());
  (void)c.end_checkpoint();
  EXPECT_TRUE(c.asked()) << "the rollback still waits for its safe point";
}

TEST(ImageCoordinator, Abandoned_OwedAnswersSettledOnceEach_ForgottenAtACommit) {
  ImageCoordinator c;
  EXPECT_FALSE(c.owes(ServiceId{1}));
  c.abandoned(Generation{3}, {ServiceId{1}, ServiceId{2}});
  EXPECT_TRUE(c.owes(ServiceId{1}));
  EXPECT_FALSE(c.settle_owed(Generation{4}, ServiceId{1})) << "another generation's answer is not owed";
  EXPECT_FALSE(c.settle_owed(Generation{3}, ServiceId{9})) << "nor another service's";
  EXPECT_TRUE(c.settle_owed(Generation{3}, ServiceId{1}));
  EXPECT_FALSE(c.owes(ServiceId{1}));
  EXPECT_FALSE(c.settle_owed(Generation{3}, ServiceId{1})) << "settled once";
  EXPECT_TRUE(c.owes(ServiceId{2}));
  c.forget_abandoned();
  EXPECT_FALSE(c.owes(ServiceId{2})) << "after a commit an image still owed is a stray";
}

TEST(ImageCoordinator, ImageWork_DueAtTheControlUpdateOrItsDeadline_TakenOnce) {
  ImageCoordinator c;
  EXPECT_FALSE(c.work_left());
  EXPECT_EQ(c.work_deadline(), std::nullopt);
  EXPECT_FALSE(c.work_due(Nanos{0}));
  c.control_update_routed();  // before any work: does not make the next one due
  c.leave_work(ImageWork{.patches = Generation{2}, .evicted = {}, .sweep = "a commit",
                         .sweep_wait = SweepWait::No, .spares = Generation{2}},
               milliseconds{100});
  EXPECT_TRUE(c.work_left());
  EXPECT_EQ(c.work_deadline(), Nanos{milliseconds{100}});
  EXPECT_FALSE(c.work_due(milliseconds{99}));
  EXPECT_TRUE(c.work_due(milliseconds{100})) << "due at its deadline without a control update";
  c.control_update_routed();
  EXPECT_TRUE(c.work_due(milliseconds{0})) << "due at the control update";
  const std::optional<ImageWork> work = c.take_work();
  ASSERT_TRUE(work.has_value());
  EXPECT_EQ(work->patches, Generation{2});
  EXPECT_EQ(work->sweep, "a commit");
  EXPECT_FALSE(c.work_left());
  EXPECT_FALSE(c.take_work().has_value()) << "taken once";

  c.leave_work(ImageWork{}, milliseconds{200});
  EXPECT_FALSE(c.work_due(milliseconds{150})) << "a new left work waits for a new control update";
}

TEST(ImageCoordinator, Timer_ArmedOncePerEpoch_PeriodicRunsOnAfterARollback_OnceIsSpent) {
  ImageCoordinator c;
  EXPECT_EQ(c.timer_due(), std::nullopt);
  EXPECT_FALSE(c.armed_in(Epoch{0}));
  c.arm_timer(Epoch{0}, milliseconds{500}, milliseconds{500});
  EXPECT_TRUE(c.armed_in(Epoch{0}));
  EXPECT_FALSE(c.armed_in(Epoch{1}));
  EXPECT_EQ(c.timer_due(), Nanos{milliseconds{500}});
  c.timer_fired();
  EXPECT_EQ(c.timer_due(), std::nullopt);
  c.rejuvenated(milliseconds{510});
  EXPECT_EQ(c.timer_due(), Nanos{milliseconds{1010}}) << "periodic: a period from the rollback";

  c.arm_timer(Epoch{1}, milliseconds{2000}, Nanos{0});
  c.rejuvenated(milliseconds{1500});
  EXPECT_EQ(c.timer_due(), std::nullopt) << "once: a rollback spends it";
  c.reset_timer();
  EXPECT_FALSE(c.armed_in(Epoch{1})) << "a cold restart makes it armable again";
}

TEST(ImageCoordinatorDeathTest, IllegalTransitions_BreakTheInvariant) {
  EXPECT_DEATH({ ImageCoordinator c; (void)c.begin_checkpoint(Generation{1}, Nanos{0}); },
               "a checkpoint begins only when asked");
  EXPECT_DEATH({ ImageCoordinator c; (void)c.end_checkpoint(); }, "no checkpoint is running");
  EXPECT_DEATH({ ImageCoordinator c; c.void_ask(); }, "no checkpoint is asked");
  EXPECT_DEATH({ ImageCoordinator c; (void)c.take_rollback(); }, "no rollback is asked");
  EXPECT_DEATH(
      {
        ImageCoordinator c;
        c.leave_work(ImageWork{}, Nanos{0});
        c.leave_work(ImageWork{}, Nanos{0});
      },
      "image work is run before");
  EXPECT_DEATH(
      {
        ImageCoordinator c;
        c.arm_timer(Epoch{2}, Nanos{1}, Nanos{0});
        c.arm_timer(Epoch{2}, Nanos{1}, Nanos{0});
      },
      "at most once per epoch");
  EXPECT_DEATH({ ImageCoordinator c; c.timer_fired(); }, "was not due");
}

}  // namespace
}  // namespace rejuv::kernel
