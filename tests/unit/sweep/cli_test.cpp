// `rejuv sweep` as a user runs it, on the model (fast): the outputs, resume, shards and merge, bad input.
#include <gtest/gtest.h>
#include <google/protobuf/util/json_util.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "../../rejuv_cli.hpp"
#include "sweep.pb.h"

namespace rejuv {
namespace {

namespace fs = std::filesystem;
using test_support::run_rejuv;
using test_support::slurp;

const std::string kGraph = (test_support::kRepo / "launch" / "quad_square_paper.launch.pbtxt").string();

class SweepCli : public test_support::ScratchDirTest {
 protected:
  SweepCli() : ScratchDirTest("rejuv_sweep_cli_") {}
  // A 2 × 2 grid, 2 attacks per cell (a few seconds of flight each).
  test_support::CliOutcome sweep(const fs::path& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"sweep", kGraph, "--param", "sr.t_mc_s=0.2,0.3", "--param", "sr.t_est_s=1:2:1",
                                     "--attacks", "2", "--seeds", "1", "--jobs", "2", "--out", out.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_rejuv(dir_, args);
  }
};

proto::SweepReport report_of(const fs::path& out) {
  proto::SweepReport r;
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(out / "sweep.json"), &r).ok());
  return r;
}

// Without --seeds a cell flies the graph's seed (1) and the next two: one seed is one sample of noise and wind.
TEST_F(SweepCli, NoSeedsGiven_ThreeSeedsFromTheGraphs) {
  const fs::path out = dir_ / "d";
  const auto r = run_rejuv(dir_, {"sweep", kGraph, "--param", "sr.t_mc_s=0.3", "--attacks", "1", "--out", out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const proto::SweepReport report = report_of(out);
  ASSERT_EQ(report.plan().seeds_size(), 3);
  EXPECT_EQ(report.plan().seeds(0), 1U);
  EXPECT_EQ(report.plan().seeds(2), 3U);
  ASSERT_EQ(report.cells_size(), 1);
  EXPECT_EQ(report.cells(0).seeds(), 3U);
}

TEST_F(SweepCli, SimSweep_WritesCsvJsonAndFigures) {
  const fs::path out = dir_ / "s";
  const auto r = sweep(out);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const proto::SweepReport report = report_of(out);
  ASSERT_EQ(report.cells_size(), 4);
  EXPECT_EQ(report.missing(), 0U);
  for (const proto::SweepCellResult& c : report.cells()) {
    EXPECT_EQ(c.runner(), "sim");
    EXPECT_EQ(c.ok(), 1U);
    EXPECT_EQ(c.completed(), 1U);  // stopped after the attacks: not a failed mission
    EXPECT_DOUBLE_EQ(c.attacks().max(), 2.0);
    EXPECT_GT(c.max_v().max(), 0.0);
    EXPECT_GT(c.max_est_err_p().max(), 0.0);
  }
  EXPECT_EQ(report.cells(3).params(0).value(), "0.3");
  EXPECT_EQ(report.cells(3).params(1).value(), "2");
  const std::string csv = slurp(out / "sweep.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5) << csv;
  EXPECT_EQ(csv.rfind("sr.t_mc_s,sr.t_est_s,runner,", 0), 0U) << csv;
  for (const char* f : {"fig11a.png", "fig11a.svg", "fig11b.png", "fig11b.svg"}) {
    EXPECT_GT(fs::file_size(out / f), 1000U) << f;
  }
  EXPECT_EQ(slurp(out / "fig11a.png").substr(1, 3), "PNG");
}

// The charge per checkpoint/rollback each row was flown with (sweep.csv's columns checkpoint_charge_ms and
// rollback_charge_ms, the two before `error`), one pair per data row.
std::vector<std::pair<double, double>> charges_in(const std::string& csv) {
  std::vector<std::pair<double, double>> out;
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    const auto error = line.rfind(',');
    const auto rb = line.rfind(',', error - 1);
    const auto cp = line.rfind(',', rb - 1);
    out.emplace_back(std::stod(line.substr(cp + 1, rb - cp - 1)), std::stod(line.substr(rb + 1, error - rb - 1)));
  }
  return out;
}

// The model charges the paper's T_CP/T_RB unless told to charge the launch file's lockstep charges (the
// square: 0.3/0.3 ms), as the runtime does; sweep.csv and the table say which, and a sweep with other charges
// is another sweep.
TEST_F(SweepCli, ChargesRuntime_TheModelChargesTheLaunchFilesLockstep) {
  const fs::path own = dir_ / "own";
  const auto a = sweep(own);
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const std::string own_csv = slurp(own / "sweep.csv");
  EXPECT_NE(own_csv.find(",checkpoint_charge_ms,rollback_charge_ms,error\n"), std::string::npos) << own_csv;
  for (const auto& [cp, rb] : charges_in(own_csv)) {
    EXPECT_DOUBLE_EQ(cp, 20.0) << own_csv;
    EXPECT_DOUBLE_EQ(rb, 15.0) << own_csv;
  }
  EXPECT_NE(a.out.find("charged per checkpoint/rollback: sim 20/15 ms (each runner its own"), std::string::npos) << a.out;

  const fs::path like = dir_ / "like";
  const auto b = sweep(like, {"--charges", "runtime"});
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto charged = charges_in(slurp(like / "sweep.csv"));
  ASSERT_EQ(charged.size(), 4U);
  for (const auto& [cp, rb] : charged) {
    EXPECT_DOUBLE_EQ(cp, 0.3);
    EXPECT_DOUBLE_EQ(rb, 0.3);
  }
  EXPECT_NE(b.out.find("(--charges runtime)"), std::string::npos) << b.out;
  // Less stop per cycle: the same cells fly with a lower or equal max V (the stop holds the controls).
  EXPECT_LE(report_of(like).cells(3).max_v().max(), report_of(own).cells(3).max_v().max() + 1e-9);

  const auto resumed = sweep(own, {"--resume", "--charges", "paper"});
  EXPECT_EQ(resumed.exit_code, 2);
  EXPECT_NE(resumed.err.find("another sweep"), std::string::npos) << resumed.err;
}

TEST_F(SweepCli, Resume_FliesNothingTwice) {
  const fs::path out = dir_ / "s";
  ASSERT_EQ(sweep(out).exit_code, 0);
  fs::remove(out / "cells" / "cell-0002_seed-1_sim.json");  // as if interrupted before that one
  const auto r = sweep(out, {"--resume"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("1 tasks to fly, 3 kept"), std::string::npos) << r.err;
  EXPECT_EQ(report_of(out).missing(), 0U);
}

TEST_F(SweepCli, ExistingSweepWithoutResume_Refused) {
  const fs::path out = dir_ / "s";
  ASSERT_EQ(sweep(out).exit_code, 0);
  const auto r = sweep(out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--resume"), std::string::npos) << r.err;
}

TEST_F(SweepCli, ResumeOfAnotherSweep_Refused) {
  const fs::path out = dir_ / "s";
  ASSERT_EQ(sweep(out).exit_code, 0);
  const auto r = run_rejuv(dir_, {"sweep", kGraph, "--seeds", "1", "--param", "sr.t_mc_s=0.2", "--attacks", "2", "--out",
                                  out.string(), "--resume"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("another sweep"), std::string::npos) << r.err;
}

TEST_F(SweepCli, ShardsMerged_SameAsOneSweep) {
  const fs::path a = dir_ / "a", b = dir_ / "b", whole = dir_ / "whole";
  ASSERT_EQ(sweep(a, {"--shard", "1/2"}).exit_code, 0);
  ASSERT_EQ(sweep(b, {"--shard", "2/2"}).exit_code, 0);
  EXPECT_EQ(report_of(a).cells_size(), 2);
  const auto m = run_rejuv(dir_, {"sweep", "merge", a.string(), b.string(), "--out", (dir_ / "m").string()});
  ASSERT_EQ(m.exit_code, 0) << m.err;
  ASSERT_EQ(sweep(whole).exit_code, 0);
  EXPECT_EQ(slurp(dir_ / "m" / "sweep.csv"), slurp(whole / "sweep.csv"));  // the model is deterministic
  EXPECT_TRUE(fs::exists(dir_ / "m" / "fig11a.png"));
}

TEST_F(SweepCli, MergeOfDifferentSweeps_Refused) {
  ASSERT_EQ(sweep(dir_ / "a", {"--shard", "1/2"}).exit_code, 0);
  ASSERT_EQ(run_rejuv(dir_, {"sweep", kGraph, "--seeds", "1", "--param", "sr.t_mc_s=0.2", "--attacks", "2", "--out",
                             (dir_ / "b").string()})
                .exit_code,
            0);
  const auto m = run_rejuv(dir_, {"sweep", "merge", (dir_ / "a").string(), (dir_ / "b").string()});
  EXPECT_EQ(m.exit_code, 2);
  EXPECT_NE(m.err.find("another sweep"), std::string::npos) << m.err;
}

TEST_F(SweepCli, OneParameter_LinePlot) {
  const fs::path out = dir_ / "s";
  // Ū of 10–20 % of the way to each limit loses the vehicle (max V ≈ 100): studied here, so --allow-unsafe.
  const auto r = run_rejuv(dir_, {"sweep", kGraph, "--param", "sr.restricted_limit_fraction=0.1,0.2", "--attacks", "2",
                                  "--seeds", "1-2", "--allow-unsafe", "--out", out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const proto::SweepReport report = report_of(out);
  ASSERT_EQ(report.cells_size(), 2);
  EXPECT_EQ(report.cells(0).records_size(), 2);
  EXPECT_TRUE(fs::exists(out / "fig11a.svg"));
}

TEST_F(SweepCli, InvalidCell_ReportedNotCrashedOn) {
  // ρ_s must stay below ρ_M: the cell with ρ_s = 0.5 is refused by the launch checks, the other flies.
  const fs::path out = dir_ / "s";
  const auto r = run_rejuv(dir_, {"sweep", kGraph, "--seeds", "1", "--param", "sr.rho_s=0.05,0.5", "--attacks", "2", "--out",
                                  out.string()});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  const proto::SweepReport report = report_of(out);
  ASSERT_EQ(report.cells_size(), 2);
  EXPECT_EQ(report.cells(0).ok(), 1U);
  EXPECT_EQ(report.cells(1).ok(), 0U);
  EXPECT_NE(report.cells(1).error().find("rho_s"), std::string::npos) << report.cells(1).error();
  EXPECT_NE(slurp(out / "sweep.csv").find("rho_s"), std::string::npos);
}

// A cell that left the safety set is not a success. T_MC = 3 s under the worst-case attack
// takes the model out of it (max V > 1): exit 1 with the cell named; --allow-unsafe: exit 0, the same report.
TEST_F(SweepCli, CellLeavesTheSafetySet_Exit1UnlessAllowUnsafe) {
  const std::vector<std::string> args = {"sweep", kGraph, "--seeds", "1", "--param", "sr.t_mc_s=0.3,3", "--attacks", "2"};
  std::vector<std::string> strict = args;
  strict.insert(strict.end(), {"--out", (dir_ / "strict").string()});
  const auto r = run_rejuv(dir_, strict);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("1 cell LEFT THE SAFETY SET"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("LEFT THE SAFETY SET"), std::string::npos) << r.out;
  const proto::SweepReport report = report_of(dir_ / "strict");
  ASSERT_EQ(report.cells_size(), 2);
  EXPECT_EQ(report.cells(0).safe(), 1U);
  EXPECT_EQ(report.cells(1).safe(), 0U);
  EXPECT_GE(report.cells(1).max_v().max(), 1.0);
  EXPECT_GT(report.cells(1).mission_time_s().max(), 0.0);
  EXPECT_NE(slurp(dir_ / "strict" / "sweep.csv").find("mission_time_s_mean"), std::string::npos);
  std::vector<std::string> allowed = args;
  allowed.insert(allowed.end(), {"--allow-unsafe", "--out", (dir_ / "allowed").string()});
  const auto a = run_rejuv(dir_, allowed);
  EXPECT_EQ(a.exit_code, 0) << a.err;
  EXPECT_NE(a.err.find("1 cell LEFT THE SAFETY SET"), std::string::npos) << a.err;
}

TEST_F(SweepCli, BadInput_PreciseErrorExit2) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--param", "sr.t_mcs=1:2:1"}, "has no field 't_mcs'"},
      {{"--param", "sr.t_mc_s=3:1:1"}, "inverted"},
      {{"--param", "sr.t_mc_s=1:2:0"}, "step must be > 0"},
      {{"--param", "attack.attacks[0].kind=1:2:1"}, "needs a numeric field"},
      {{"--param", "attack.attacks[5].kind=ARM_TIMER"}, "the launch has 1 element"},
      {{"--param", "sr=1"}, "is a message"},
      {{"--param", "sr.t_mc_s=0.2", "--param", "sr.t_mc_s=0.3"}, "given twice"},
      {{"--param", "sr.t_mc_s=0.2", "--runner", "fast"}, "--runner"},
      {{"--param", "sr.t_mc_s=0.2", "--jobs", "0"}, "--jobs"},
      {{"--param", "sr.t_mc_s=0.2", "--seeds", "5-1"}, "inverted"},
      {{"--param", "sr.t_mc_s=0.2", "--shard", "3/2"}, "--shard"},
      {{}, "missing option --param PATH=VALUES"},
  };
  for (const auto& [extra, expected] : cases) {
    std::vector<std::string> args = {"sweep", kGraph, "--out", (dir_ / "never").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = run_rejuv(dir_, args);
    EXPECT_EQ(r.exit_code, 2) << expected << ": " << r.err;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "never"));
  const auto m = run_rejuv(dir_, {"sweep", "merge", (dir_ / "nothing").string()});
  EXPECT_EQ(m.exit_code, 2);
  EXPECT_NE(m.err.find("no plan.json"), std::string::npos) << m.err;
}

}  // namespace
}  // namespace rejuv
