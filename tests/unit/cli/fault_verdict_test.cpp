// The fault campaign's verdicts (tools/rejuv/fault_plan.cpp judge; docs/design.md §7 "Faults"): each one from the
// facts it is taken from, and an outcome with each verdict through the job → campaign record and back.
#include <gtest/gtest.h>

#include "fault_campaign.hpp"

namespace rejuv::cli::faults {
namespace {

VerdictInput base(FaultKind kind, std::string path) {
  return VerdictInput{.kind = kind, .target = "ekf2", .path = std::move(path), .back = true, .max_v = 0.2,
                      .max_v_at_fire = 0.1};
}

TEST(FaultVerdict, TargetSeenBack_Recovered) {
  const Verdict v = judge(base(FaultKind::KillLive, "rollback"));
  EXPECT_TRUE(v.recovered);
  EXPECT_TRUE(v.not_judged.empty());
  EXPECT_FALSE(v.unsafe);
}

TEST(FaultVerdict, NextFaultBeforeTheTargetIsBack_NotJudgedNotFailed) {
  VerdictInput in = base(FaultKind::KillLive, "cold restart");
  in.back = false;
  in.next_fault = true;
  const Verdict v = judge(in);
  EXPECT_FALSE(v.recovered);
  EXPECT_EQ(v.not_judged, "the next fault came before 'ekf2' was seen back");
  EXPECT_EQ(v.note.find("not back"), std::string::npos);
}

TEST(FaultVerdict, MissionEndBeforeTheTargetIsBack_NotJudged) {
  VerdictInput in = base(FaultKind::HangLive, "none needed");
  in.back = false;
  in.ended = true;
  EXPECT_EQ(judge(in).not_judged, "the mission ended before 'ekf2' was seen back");
}

TEST(FaultVerdict, TenSecondsOfFlightWithoutTheTarget_NotRecovered) {
  VerdictInput in = base(FaultKind::KillLive, "none needed");
  in.back = false;
  const Verdict v = judge(in);
  EXPECT_FALSE(v.recovered);
  EXPECT_TRUE(v.not_judged.empty()) << "a true failure is judged, not set aside";
  EXPECT_NE(v.note.find("'ekf2' not back within 10 s of flight"), std::string::npos) << v.note;
}

TEST(FaultVerdict, BackButTheRunStopping_NotRecovered) {
  VerdictInput in = base(FaultKind::KillLive, "rollback");
  in.stopped = true;
  EXPECT_FALSE(judge(in).recovered);
  in.ended = true;  // at the mission's end every run has stopped: that is no failure
  EXPECT_TRUE(judge(in).recovered);
}

TEST(FaultVerdict, ColdRestartAfterOneImage_AFindingOnlyWhenAnotherGenerationWasInTheStore) {
  VerdictInput in = base(FaultKind::KillImage, "cold restart");
  in.others_at_fire = 1;
  Verdict v = judge(in);
  EXPECT_FALSE(v.recovered);
  EXPECT_NE(v.note.find("although an intact generation was left"), std::string::npos) << v.note;
  in.others_at_fire = 0;  // after a fallback or a cold restart: the hit generation was the only one
  v = judge(in);
  EXPECT_TRUE(v.recovered);
  EXPECT_NE(v.note.find("no other generation was in the store"), std::string::npos) << v.note;
  in.others_at_fire = 1;
  in.keep = 1;  // one generation kept: nothing else to fall back to
  EXPECT_TRUE(judge(in).recovered);
  in.kind = FaultKind::KillImages;  // every image: a cold restart is the only recovery
  in.keep = 2;
  EXPECT_TRUE(judge(in).recovered);
}

TEST(FaultVerdict, MaxVCrossingOneAfterTheFault_Unsafe) {
  VerdictInput in = base(FaultKind::StopImage, "fallback to an earlier generation");
  in.max_v = 1.4;
  EXPECT_TRUE(judge(in).unsafe);
  in.max_v_at_fire = 1.2;  // already out when it fired: not this fault's doing
  EXPECT_FALSE(judge(in).unsafe);
}

TEST(FaultVerdict, OutcomeRecord_CarriesTheVerdictBetweenJobAndCampaign) {
  Outcome o;
  o.mission = 3;
  o.fault = Planned{.kind = FaultKind::HangLive, .where = Where::SecureInterval, .target = "ext_link",
                    .at = Nanos{1'500'000'000}};
  o.fired = true;
  o.fired_at_s = 1.6;
  o.path = "rollback";
  o.not_judged = "the next fault came before 'ext_link' was seen back";
  o.note = "1 process (pid 42)";
  o.recovery_ms = 12.5;
  Outcome back;
  ASSERT_TRUE(decode(encode(o), back));
  EXPECT_EQ(back.not_judged, o.not_judged);
  EXPECT_EQ(back.note, o.note);
  EXPECT_EQ(back.fault.target, "ext_link");
  EXPECT_FALSE(back.recovered);
  EXPECT_DOUBLE_EQ(back.recovery_ms, 12.5);
  EXPECT_FALSE(decode("3\t1\t2\text_link", back)) << "a short record is refused";
}

}  // namespace
}  // namespace rejuv::cli::faults
