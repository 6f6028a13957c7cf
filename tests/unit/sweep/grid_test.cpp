// The bookkeeping of `rejuv sweep`: cells, seeds, shards, cell launches, records kept and read back, the
// aggregate over the seeds and its CSV.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "sweep/figures.hpp"
#include "sweep/grid.hpp"

namespace rejuv::cli::sweep {
namespace {

namespace fs = std::filesystem;

proto::SweepPlan plan_2x3() {
  proto::SweepPlan p;
  p.set_graph("/x/quad.launch.pbtxt");
  proto::SweepAxis* a = p.add_axes();
  a->set_path("sr.t_mc_s");
  for (const char* v : {"0.2", "0.3"}) a->add_values(v);
  proto::SweepAxis* b = p.add_axes();
  b->set_path("sr.t_est_s");
  for (const char* v : {"1", "2", "3"}) b->add_values(v);
  p.add_seeds(1);
  p.add_seeds(2);
  p.set_attacks(45);
  p.add_runners("sim");
  p.add_runners("run");
  return p;
}

proto::SweepRecord ok_record(const proto::SweepPlan& plan, std::uint32_t cell, std::uint64_t seed, const char* runner,
                             double max_V) {
  proto::SweepRecord r;
  r.set_cell(cell);
  for (const proto::SweepParamValue& p : cell_params(plan, cell)) *r.add_params() = p;
  r.set_seed(seed);
  r.set_runner(runner);
  r.set_attacks(plan.attacks());
  r.set_status("ok");
  r.mutable_summary()->set_max_v(max_V);
  r.mutable_summary()->set_attacks(45);
  r.mutable_summary()->set_stopped_after_attacks(true);
  return r;
}

class GridTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rejuv_sweep_grid_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_ / "cells");
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

TEST(Cells, Product_OuterAxisFirst) {
  const proto::SweepPlan p = plan_2x3();
  EXPECT_EQ(cell_count(p), 6U);
  const auto c4 = cell_params(p, 4);  // (0.3, 2)
  ASSERT_EQ(c4.size(), 2U);
  EXPECT_EQ(c4[0].value(), "0.3");
  EXPECT_EQ(c4[1].value(), "2");
}

TEST(Tasks, AllShards_CoverEveryTaskOnce) {
  const proto::SweepPlan p = plan_2x3();
  const auto all = tasks_of(p, Shard{});
  EXPECT_EQ(all.size(), 6U * 2 * 2);
  EXPECT_EQ(all.front().runner, Runner::Sim);  // the model first
  std::size_t total = 0;
  for (std::uint32_t i = 0; i < 4; ++i) {
    const auto part = tasks_of(p, Shard{.index = i, .count = 4});
    for (const Task& t : part) EXPECT_EQ(t.cell % 4, i);
    total += part.size();
  }
  EXPECT_EQ(total, all.size());
}

TEST(ParseShard, Valid_ZeroBasedIndex) {
  const auto s = parse_shard("2/8");
  ASSERT_TRUE(s) << s.error();
  EXPECT_EQ(s->index, 1U);
  EXPECT_EQ(s->count, 8U);
}

TEST(ParseShard, Invalid_Refused) {
  for (const char* bad : {"0/4", "5/4", "1/0", "1", "a/b", "1/", "/3"}) EXPECT_FALSE(parse_shard(bad)) << bad;
}

TEST(ParseSeeds, RangesAndLists_Expanded) {
  EXPECT_EQ(*parse_seeds("1-5"), (std::vector<std::uint64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(*parse_seeds("3,7,9-10"), (std::vector<std::uint64_t>{3, 7, 9, 10}));
}

TEST(ParseSeeds, Invalid_Refused) {
  for (const char* bad : {"", "5-1", "a", "1,,2", "1-", "1,1"}) EXPECT_FALSE(parse_seeds(bad)) << bad;
}

TEST(CellLaunch, ValuesStopAndAbsolutePaths_Set) {
  proto::Launch base;
  base.set_policy("../policies/p.pbtxt");
  base.mutable_dds()->set_config("cfg.xml");
  const auto l = cell_launch(base, "/repo/launch", plan_2x3(), 5);
  ASSERT_TRUE(l) << l.error();
  EXPECT_DOUBLE_EQ(l->sr().t_mc_s(), 0.3);
  EXPECT_DOUBLE_EQ(l->sr().t_est_s(), 3.0);
  EXPECT_EQ(l->stop_after_attacks(), 45U);
  EXPECT_EQ(l->policy(), "/repo/policies/p.pbtxt");
  EXPECT_EQ(l->dds().config(), "/repo/launch/cfg.xml");
}

// Sweeping the attack kind moves a kind of the attack library to the service that carries it (as
// `--attack` does); a kind the named service carries stays there.
TEST(CellLaunch, SweptAttackKind_MovesToItsService) {
  proto::Launch base;
  for (const auto& [name, exe] : {std::pair{"lqr_control", "rejuv_lqr_control"}, std::pair{"ekf2", "rejuv_ekf2"},
                                  std::pair{"sensors", "rejuv_sensors"}}) {
    proto::ServiceSpec* s = base.add_services();
    s->set_name(name);
    s->set_executable(exe);
  }
  proto::Attack* a = base.mutable_attack()->add_attacks();
  a->set_kind(proto::WORST_CASE_CONTROL);
  a->set_service("lqr_control");
  proto::SweepPlan plan;
  plan.set_graph("/x/quad.launch.pbtxt");
  proto::SweepAxis* axis = plan.add_axes();
  axis->set_path("attack.attacks[0].kind");
  for (const char* v : {"ESTIMATE_SHIFT", "SENSOR_BIAS", "GAIN_OVERWRITE"}) axis->add_values(v);
  plan.add_seeds(1);
  plan.add_runners("sim");
  const char* expected[] = {"ekf2", "sensors", "lqr_control"};
  for (std::uint32_t c = 0; c < 3; ++c) {
    const auto l = cell_launch(base, "/repo/launch", plan, c);
    ASSERT_TRUE(l) << l.error();
    EXPECT_EQ(l->attack().attacks(0).service(), expected[c]) << axis->values(static_cast<int>(c));
  }
}

TEST_F(GridTest, RecordWritten_KeptForItsTaskOnly) {
  const proto::SweepPlan p = plan_2x3();
  ASSERT_TRUE(write_record(dir_, ok_record(p, 3, 2, "run", 0.4)));
  EXPECT_TRUE(kept_record(dir_, p, Task{.cell = 3, .seed = 2, .runner = Runner::Run}));
  EXPECT_FALSE(kept_record(dir_, p, Task{.cell = 3, .seed = 2, .runner = Runner::Sim}));
  EXPECT_FALSE(kept_record(dir_, p, Task{.cell = 3, .seed = 1, .runner = Runner::Run}));
}

TEST_F(GridTest, RecordOfAnotherPlan_NotKept) {
  const proto::SweepPlan p = plan_2x3();
  ASSERT_TRUE(write_record(dir_, ok_record(p, 3, 2, "run", 0.4)));
  proto::SweepPlan other = p;
  other.mutable_axes(1)->set_values(0, "4");  // cell 3 is (0.3, 1): its values differ
  EXPECT_FALSE(kept_record(dir_, other, Task{.cell = 3, .seed = 2, .runner = Runner::Run}));
  other = p;
  other.set_attacks(10);
  EXPECT_FALSE(kept_record(dir_, other, Task{.cell = 3, .seed = 2, .runner = Runner::Run}));
}

TEST_F(GridTest, TornRecord_NotKept) {
  const proto::SweepPlan p = plan_2x3();
  const Task t{.cell = 1, .seed = 1, .runner = Runner::Sim};
  std::ofstream(record_path(dir_, t)) << "{\"cell\": 1, \"seed\":";
  EXPECT_FALSE(kept_record(dir_, p, t));
  EXPECT_TRUE(kept_records(dir_, p).empty());
}

TEST_F(GridTest, Plan_WrittenAndReadBack) {
  const proto::SweepPlan p = plan_2x3();
  ASSERT_TRUE(write_plan(dir_, p));
  const auto back = read_plan(dir_);
  ASSERT_TRUE(back) << back.error();
  EXPECT_TRUE(same_plan(*back, p));
  EXPECT_FALSE(read_plan(dir_ / "cells"));
}

TEST(Aggregate, Seeds_MaxAndMeanAndMissing) {
  const proto::SweepPlan p = plan_2x3();
  std::vector<proto::SweepRecord> records = {ok_record(p, 0, 1, "sim", 0.2), ok_record(p, 0, 2, "sim", 0.4)};
  proto::SweepRecord refused = ok_record(p, 1, 1, "sim", 0);
  refused.set_status("invalid");
  refused.set_error("launch.pbtxt:3:1: error: no");
  records.push_back(refused);
  const proto::SweepReport r = aggregate(p, records);
  ASSERT_EQ(r.cells_size(), 2);
  EXPECT_DOUBLE_EQ(r.cells(0).max_v().max(), 0.4);
  EXPECT_DOUBLE_EQ(r.cells(0).max_v().mean(), 0.3);
  EXPECT_EQ(r.cells(0).ok(), 2U);
  EXPECT_EQ(r.cells(0).completed(), 2U);
  EXPECT_EQ(r.cells(1).ok(), 0U);
  EXPECT_NE(r.cells(1).error().find("error: no"), std::string::npos);
  EXPECT_EQ(r.missing(), 6U * 2 * 2 - 3);
  const std::string csv = to_csv(r);
  EXPECT_NE(csv.find("sr.t_mc_s,sr.t_est_s,runner,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("0.2,1,sim,2,2,2,2,0.4,0.3,"), std::string::npos) << csv;
}


// A mission that completed before the plan's N attacks: the cell is flagged (how many seeds, the fewest attacks),
// in the report and the CSV.
TEST(Aggregate, MissionEndedBeforeTheAttacks_CellFlaggedShort) {
  const proto::SweepPlan p = plan_2x3();
  proto::SweepRecord ended = ok_record(p, 0, 2, "sim", 0.1);
  ended.mutable_summary()->set_attacks(40);
  ended.mutable_summary()->set_stopped_after_attacks(false);
  ended.mutable_summary()->set_mission_completed(true);
  const proto::SweepReport r = aggregate(p, {ok_record(p, 0, 1, "sim", 0.2), ended, ok_record(p, 1, 1, "sim", 0.2)});
  ASSERT_EQ(r.cells_size(), 2);
  EXPECT_EQ(r.cells(0).short_of_attacks(), 1U);
  EXPECT_EQ(r.cells(0).attacks_min(), 40U);
  EXPECT_EQ(r.cells(1).short_of_attacks(), 0U);
  EXPECT_EQ(r.cells(1).attacks_min(), 45U);
  const std::string csv = to_csv(r);
  EXPECT_NE(csv.find(",attacks_min,attacks_mean,short_of_attacks,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",40,42.5,1,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",45,45,0,"), std::string::npos) << csv;
}

// The variables `rejuv sweep` hands gnuplot for Fig. 11(a) (DIR/plot/fig11a.vars.gp, written before gnuplot runs).
std::string fig11a_vars(const fs::path& dir, const proto::SweepReport& report) {
  (void)draw_figures(dir, report, fs::path(REJUV_SOURCE_DIR) / "tools" / "plots" / "sweep.gp");
  std::ifstream in(dir / "plot" / "fig11a.vars.gp");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

proto::SweepPlan plan_kind_by_test() {
  proto::SweepPlan p = plan_2x3();
  proto::SweepAxis* kind = p.mutable_axes(0);
  kind->set_path("attack.attacks[0].kind");
  kind->clear_values();
  for (const char* v : {"WORST_CASE_CONTROL", "SENSOR_BIAS"}) kind->add_values(v);
  p.clear_runners();
  p.add_runners("sim");
  return p;
}

TEST_F(GridTest, EnumAxis_DrawnAsCategories) {
  const proto::SweepPlan p = plan_kind_by_test();
  const std::string vars = fig11a_vars(dir_, aggregate(p, {ok_record(p, 0, 1, "sim", 0.2)}));
  EXPECT_NE(vars.find("categorical=1"), std::string::npos) << vars;
  EXPECT_NE(vars.find("xtics_text='(\"WORST_CASE_CONTROL\" 0, \"SENSOR_BIAS\" 1)'"), std::string::npos) << vars;
  const std::string numeric = fig11a_vars(dir_, aggregate(plan_2x3(), {ok_record(plan_2x3(), 0, 1, "sim", 0.2)}));
  EXPECT_NE(numeric.find("categorical=0"), std::string::npos) << numeric;
}

TEST_F(GridTest, CellsShortOfTheAttacks_TitleSaysUpToAndTheDataMarksThem) {
  const proto::SweepPlan p = plan_kind_by_test();
  proto::SweepRecord ended = ok_record(p, 1, 1, "sim", 0.1);
  ended.mutable_summary()->set_attacks(38);
  const proto::SweepReport r = aggregate(p, {ok_record(p, 0, 1, "sim", 0.2), ended});
  const std::string vars = fig11a_vars(dir_, r);
  EXPECT_NE(vars.find("subtitle='up to 45 attacks per cell (1 of 2 cells fewer: marked *)"), std::string::npos) << vars;
  EXPECT_EQ(vars.find("'45 attacks per cell"), std::string::npos) << vars;
  std::ifstream dat(dir_ / "plot" / "sim.dat");
  std::string line, all;
  while (std::getline(dat, line)) all += line + "\n";
  EXPECT_NE(all.find("0 1 0.2 0 0.2 0 0 45\n"), std::string::npos) << all;  // cell 0: 45 attacks
  EXPECT_NE(all.find("0 2 0.1 0 0.1 0 1 38\n"), std::string::npos) << all;  // cell 1: short, 38
}

TEST_F(GridTest, EveryCellFlewItsAttacks_TitleSaysSo) {
  const proto::SweepPlan p = plan_kind_by_test();
  const std::string vars = fig11a_vars(dir_, aggregate(p, {ok_record(p, 0, 1, "sim", 0.2)}));
  EXPECT_NE(vars.find("subtitle='45 attacks per cell"), std::string::npos) << vars;
}

}  // namespace
}  // namespace rejuv::cli::sweep
