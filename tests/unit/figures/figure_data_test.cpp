// The data behind the figures (tools/rejuv/figure_data.hpp), from known sequences: the intervals and marks of
// Fig. 7, the rows the compact trace keeps, and the CSVs an `--out` directory gets.
#include "figure_data.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "figures.hpp"

namespace rejuv::cli {
namespace {

using std::chrono::milliseconds;

SrEvent event(SrEventKind kind, Nanos t) { return SrEvent{.kind = kind, .t = t}; }

std::vector<std::string> lines_of(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST(ControlIntervals, ModelSequence_MarksTheIntervalTheStopLengthened) {
  // As `rejuv sim`: updates every 4 ms; a checkpoint stops the software for 20 ms after the update at 8 ms, a
  // rollback for 15 ms after the one at 32 ms; the events come at the start of each stop.
  ControlIntervals c;
  EXPECT_FALSE(c.add(Nanos{milliseconds{0}}, Nanos{milliseconds{100}}).has_value());  // the first closes nothing
  const auto i1 = c.add(Nanos{milliseconds{4}}, Nanos{milliseconds{101}});
  const auto i2 = c.add(Nanos{milliseconds{8}}, Nanos{milliseconds{102}});
  c.on_event(event(SrEventKind::Mode, Nanos{milliseconds{8}}));  // a mode change marks nothing
  c.on_event(event(SrEventKind::Checkpoint, Nanos{milliseconds{8}}));
  const auto i3 = c.add(Nanos{milliseconds{28}}, Nanos{milliseconds{110}});
  const auto i4 = c.add(Nanos{milliseconds{32}}, Nanos{milliseconds{111}});
  c.on_event(event(SrEventKind::Rollback, Nanos{milliseconds{33}}));
  const auto i5 = c.add(Nanos{milliseconds{48}}, Nanos{milliseconds{120}});
  const auto i6 = c.add(Nanos{milliseconds{52}}, Nanos{milliseconds{121}});
  ASSERT_TRUE(i1 && i2 && i3 && i4 && i5 && i6);
  EXPECT_EQ(i1->dt, Nanos{milliseconds{4}});
  EXPECT_EQ(i1->dwall, Nanos{milliseconds{1}});
  EXPECT_EQ(i1->mark, IntervalMark::None);
  EXPECT_EQ(i2->mark, IntervalMark::None);
  EXPECT_EQ(i3->dt, Nanos{milliseconds{20}});
  EXPECT_EQ(i3->dwall, Nanos{milliseconds{8}});
  EXPECT_EQ(i3->mark, IntervalMark::Checkpoint);
  EXPECT_EQ(i3->wall_mark, IntervalMark::Checkpoint);
  EXPECT_EQ(i4->mark, IntervalMark::None);  // a mark belongs to one interval only
  EXPECT_EQ(i4->wall_mark, IntervalMark::None);
  EXPECT_EQ(i5->dt, Nanos{milliseconds{16}});
  EXPECT_EQ(i5->mark, IntervalMark::Rollback);
  EXPECT_EQ(i5->wall_mark, IntervalMark::Rollback);
  EXPECT_EQ(i6->mark, IntervalMark::None);
  EXPECT_EQ(c.max_dt(), Nanos{milliseconds{20}});
  EXPECT_EQ(c.count(), 6U);
}

TEST(ControlIntervals, LockstepSequence_SimMarkOnTheChargedIntervalWallMarkOnTheRealOne) {
  // As `rejuv run` in lockstep: the checkpoint runs in the step at 8 ms (the kernel clock stands still), the
  // step's own update follows it at 8 ms, 9 ms of real time later; the 0.7 ms it took is charged to the next
  // step, whose update comes at 12.7 ms.
  ControlIntervals c;
  (void)c.add(Nanos{milliseconds{4}}, Nanos{milliseconds{100}});
  c.on_event(event(SrEventKind::Checkpoint, Nanos{milliseconds{8}}));
  const auto i1 = c.add(Nanos{milliseconds{8}}, Nanos{milliseconds{109}});
  const auto i2 = c.add(Nanos{std::chrono::microseconds{12700}}, Nanos{milliseconds{110}});
  const auto i3 = c.add(Nanos{std::chrono::microseconds{16700}}, Nanos{milliseconds{111}});
  ASSERT_TRUE(i1 && i2 && i3);
  EXPECT_EQ(i1->mark, IntervalMark::None);
  EXPECT_EQ(i1->wall_mark, IntervalMark::Checkpoint);
  EXPECT_EQ(i1->dwall, Nanos{milliseconds{9}});
  EXPECT_EQ(i2->mark, IntervalMark::Checkpoint);
  EXPECT_EQ(i2->dt, Nanos{std::chrono::microseconds{4700}});
  EXPECT_EQ(i2->wall_mark, IntervalMark::None);
  EXPECT_EQ(i3->mark, IntervalMark::None);
}

TEST(ControlIntervals, CheckpointAndRollbackInOneInterval_MarkedRollback) {
  ControlIntervals c;
  (void)c.add(Nanos{0}, Nanos{0});
  c.on_event(event(SrEventKind::Rollback, Nanos{milliseconds{1}}));
  c.on_event(event(SrEventKind::Checkpoint, Nanos{milliseconds{2}}));
  const auto i = c.add(Nanos{milliseconds{20}}, Nanos{milliseconds{20}});
  ASSERT_TRUE(i);
  EXPECT_EQ(i->mark, IntervalMark::Rollback);  // the held controls may be compromised (§VI-B)
  EXPECT_EQ(i->wall_mark, IntervalMark::Rollback);
}

TEST(ControlIntervals, EventBeforeTheFirstUpdate_MarksNothing) {
  ControlIntervals c;
  c.on_event(event(SrEventKind::Checkpoint, Nanos{0}));
  (void)c.add(Nanos{milliseconds{1}}, Nanos{0});
  const auto i = c.add(Nanos{milliseconds{5}}, Nanos{0});
  ASSERT_TRUE(i);
  EXPECT_EQ(i->mark, IntervalMark::None);
}

TEST(TraceDecimator, Compact_KeepsOneRowPerPeriodAndEveryModeChangeAndForcedRow) {
  TraceDecimator d(TraceDetail::Compact, Nanos{milliseconds{20}});
  std::vector<int> kept;
  for (int ms = 0; ms <= 60; ms += 4) {
    SrMode mode = ms >= 44 ? SrMode::RB : SrMode::MC;  // a mode change at 44 ms
    if (ms == 28) d.force();                         // an SR event before the row at 28 ms
    if (d.keep(Nanos{milliseconds{ms}}, mode)) kept.push_back(ms);
  }
  EXPECT_EQ(kept, (std::vector<int>{0, 20, 28, 40, 44, 60}));
}

TEST(TraceDecimator, Full_KeepsEveryRow) {
  TraceDecimator d(TraceDetail::Full);
  int kept = 0;
  for (int ms = 0; ms < 100; ms += 4) kept += d.keep(Nanos{milliseconds{ms}}, SrMode::MC) ? 1 : 0;
  EXPECT_EQ(kept, 25);
}

TEST(TraceDetail, Parse_AcceptsCompactAndFullOnly) {
  EXPECT_EQ(parse_trace_detail("compact").value(), TraceDetail::Compact);
  EXPECT_EQ(parse_trace_detail("full").value(), TraceDetail::Full);
  const auto bad = parse_trace_detail("every");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("expected compact or full"), std::string::npos);
}

class RunFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("rejuv_runfiles_" + std::to_string(::getpid()) + "_" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::filesystem::path dir_;
};

TEST_F(RunFilesTest, KnownSequence_WritesTheIntervalsEventsAndSummary) {
  auto files = RunFiles::open(dir_ / "a" / "b", TraceDetail::Compact);
  ASSERT_TRUE(files) << files.error();
  files->set_service_names({"sensors", "checkpoint_p"});
  files->control_update(Nanos{milliseconds{0}}, Nanos{milliseconds{0}});
  files->control_update(Nanos{milliseconds{4}}, Nanos{milliseconds{1}});
  files->sr_event(SrEvent{.kind = SrEventKind::TimerArmed, .t = Nanos{milliseconds{4}}, .epoch = Epoch{3},
                          .mode = SrMode::CP, .span = Nanos{milliseconds{300}}, .by = ServiceId{1}});
  files->sr_event(SrEvent{.kind = SrEventKind::Rollback, .t = Nanos{milliseconds{5}}, .epoch = Epoch{4},
                          .g = Generation{7}, .mode = SrMode::RB, .span = Nanos{milliseconds{1}}});
  files->control_update(Nanos{milliseconds{10}}, Nanos{milliseconds{3}});
  proto::RunSummary s;
  s.set_runner("run");
  ASSERT_TRUE(files->finish(s));
  EXPECT_EQ(s.control_interval_ms().count(), 2U);
  EXPECT_DOUBLE_EQ(s.control_interval_ms().max(), 6.0);

  const auto control = lines_of(dir_ / "a" / "b" / "control.csv");
  ASSERT_EQ(control.size(), 3U);
  EXPECT_EQ(control[0], "t_s,wall_s,interval_ms,wall_interval_ms,mark,wall_mark");
  EXPECT_EQ(control[1], "0.004000,0.001000,4.0000,1.0000,,");
  EXPECT_EQ(control[2], "0.010000,0.003000,6.0000,2.0000,RB,RB");
  const auto events = lines_of(dir_ / "a" / "b" / "events.csv");
  ASSERT_EQ(events.size(), 3U);
  EXPECT_EQ(events[1], "0.004000,0.000000,timer_armed,3,0,CP,300.0000,checkpoint_p");
  EXPECT_EQ(events[2], "0.005000,0.000000,rollback,4,7,RB,1.0000,kernel");
  EXPECT_TRUE(std::filesystem::exists(dir_ / "a" / "b" / "summary.json"));
  EXPECT_TRUE(check_run_dir(dir_ / "a" / "b"));
}

TEST_F(RunFilesTest, UnwritableDir_IsAnErrorNamingIt) {
  std::filesystem::create_directories(dir_);
  std::ofstream(dir_ / "file") << "x";
  const auto files = RunFiles::open(dir_ / "file" / "sub", TraceDetail::Full);
  ASSERT_FALSE(files);
  EXPECT_NE(files.error().find("cannot create"), std::string::npos) << files.error();
}

}  // namespace
}  // namespace rejuv::cli
