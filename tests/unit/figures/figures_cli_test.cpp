// `rejuv sim --out DIR` and `rejuv report figures DIR` as a user runs them (the real binary): the CSVs, the
// PNG and SVG figures when gnuplot is there, and a precise error (exit 2) for a directory that is not a run's.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "../../rejuv_cli.hpp"
#include "figures.hpp"

namespace {

using rejuv::test_support::count_of;
using rejuv::test_support::kRepo;
using rejuv::test_support::run_rejuv;
using rejuv::test_support::slurp;
namespace fs = std::filesystem;

class FiguresCli : public rejuv::test_support::ScratchDirTest {
 protected:
  FiguresCli() : ScratchDirTest("rejuv_figures_cli_") {}
};

// Each figure as a PNG (its signature) and an SVG, both non-empty.
void expect_figures(const fs::path& dir) {
  for (const char* name : rejuv::cli::kFigures) {
    const fs::path png = dir / (std::string(name) + ".png");
    const fs::path svg = dir / (std::string(name) + ".svg");
    ASSERT_TRUE(fs::exists(png)) << png;
    EXPECT_GT(fs::file_size(png), 0U) << png;
    EXPECT_EQ(slurp(png).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << png;
    ASSERT_TRUE(fs::exists(svg)) << svg;
    EXPECT_GT(fs::file_size(svg), 0U) << svg;
    EXPECT_NE(slurp(svg).find("<svg"), std::string::npos) << svg;
  }
}

// A run directory whose files start with these lines (nullptr: the file is missing).
void write_run_dir(const fs::path& dir, const char* trace, const char* control, const char* events) {
  for (auto [name, text] : {std::pair{"trace.csv", trace}, std::pair{"control.csv", control},
                            std::pair{"events.csv", events}}) {
    if (text != nullptr) std::ofstream(dir / name) << text;
  }
}
constexpr const char* kTraceHeader = "t_s,n_m,e_m,d_m\n";
constexpr const char* kControlHeader = "t_s,wall_s,interval_ms,wall_interval_ms,mark,wall_mark\n";
constexpr const char* kEventsHeader = "t_s,wall_s,kind,epoch,generation,mode,span_ms,by\n";

TEST_F(FiguresCli, SimOut_WritesTheCsvsAndTheFigures) {
  const auto r = run_rejuv(dir_, {"sim", (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string(), "--out",
                                  (dir_ / "sim").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string control = slurp(dir_ / "sim" / "control.csv");
  const std::string events = slurp(dir_ / "sim" / "events.csv");
  EXPECT_EQ(control.rfind(kControlHeader, 0), 0U);
  EXPECT_GT(count_of(control, ",RB,RB\n"), 10U);  // the square has dozens of rollbacks
  EXPECT_GT(count_of(control, ",CP,CP\n"), 10U);
  EXPECT_GT(count_of(events, ",rollback,"), 10U);
  EXPECT_EQ(count_of(events, ",timer_refused,"), 0U);  // one arm per epoch
  EXPECT_TRUE(fs::exists(dir_ / "sim" / "summary.json"));
  if (!rejuv::cli::find_gnuplot()) GTEST_SKIP() << "no gnuplot: the CSVs only";
  expect_figures(dir_ / "sim");

  // `rejuv report figures` draws them again from the files.
  for (const char* name : rejuv::cli::kFigures) fs::remove(dir_ / "sim" / (std::string(name) + ".png"));
  const auto again = run_rejuv(dir_, {"report", "figures", (dir_ / "sim").string()});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  expect_figures(dir_ / "sim");
}

// The no-SR baseline of a runtime mission, as a researcher flies it (short): no CP, RB or SR event to draw.
std::vector<std::string> no_sr_run(const fs::path& out) {
  return {"run", (kRepo / "launch" / "quad_square.launch.pbtxt").string(), "--no-sr", "--no-attack", "--duration", "2",
          "--out", out.string()};
}

TEST_F(FiguresCli, RunOutWithoutSr_Exit0AndEveryFigureSaysNoSr) {
  const auto r = run_rejuv(dir_, no_sr_run(dir_ / "run"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  if (!rejuv::cli::find_gnuplot()) GTEST_SKIP() << "no gnuplot: the CSVs only";
  expect_figures(dir_ / "run");
  EXPECT_NE(slurp(dir_ / "run" / "fig7_control_intervals.svg").find("no SR in this run"), std::string::npos);
  EXPECT_NE(slurp(dir_ / "run" / "fig8_sr_timeline.svg").find("no SR in this run"), std::string::npos);

  for (const char* name : rejuv::cli::kFigures) {
    fs::remove(dir_ / "run" / (std::string(name) + ".png"));
    fs::remove(dir_ / "run" / (std::string(name) + ".svg"));
  }
  const auto again = run_rejuv(dir_, {"report", "figures", (dir_ / "run").string()});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  expect_figures(dir_ / "run");
}

// REJUV_PLOTS_DIR for the children of one test.
class PlotsDirOverride {
 public:
  explicit PlotsDirOverride(const fs::path& dir) { ::setenv("REJUV_PLOTS_DIR", dir.c_str(), 1); }
  ~PlotsDirOverride() { ::unsetenv("REJUV_PLOTS_DIR"); }
  PlotsDirOverride(const PlotsDirOverride&) = delete;
  PlotsDirOverride& operator=(const PlotsDirOverride&) = delete;
};

TEST_F(FiguresCli, ReportFigures_OneScriptFails_OthersDrawnItNamed_Exit1) {
  std::vector<std::string> args = no_sr_run(dir_ / "run");
  args.emplace_back("--no-figures");
  ASSERT_EQ(run_rejuv(dir_, args).exit_code, 0);
  if (!rejuv::cli::find_gnuplot()) GTEST_SKIP() << "no gnuplot";
  fs::copy(kRepo / "tools" / "plots", dir_ / "plots");
  std::ofstream(dir_ / "plots" / "fig8_sr_timeline.gp", std::ios::trunc) << "this is no gnuplot\n";
  const PlotsDirOverride plots(dir_ / "plots");

  const auto r = run_rejuv(dir_, {"report", "figures", (dir_ / "run").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("figure fig8_sr_timeline not drawn"), std::string::npos) << r.err;
  for (const char* name : rejuv::cli::kFigures) {
    if (std::string(name) == "fig8_sr_timeline") continue;
    EXPECT_TRUE(fs::exists(dir_ / "run" / (std::string(name) + ".png"))) << name << " (drawn after the failure too)";
    EXPECT_TRUE(fs::exists(dir_ / "run" / (std::string(name) + ".svg"))) << name;
  }
}

TEST_F(FiguresCli, SimOutFullTrace_IsLargerThanCompact) {
  const std::string graph = (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string();
  ASSERT_EQ(run_rejuv(dir_, {"sim", graph, "--no-sr", "--no-attack", "--out", (dir_ / "c").string(), "--no-figures"})
                .exit_code,
            0);
  ASSERT_EQ(run_rejuv(dir_, {"sim", graph, "--no-sr", "--no-attack", "--out", (dir_ / "f").string(), "--trace", "full",
                             "--no-figures"})
                .exit_code,
            0);
  EXPECT_FALSE(fs::exists(dir_ / "c" / "fig7_control_intervals.png"));  // --no-figures: the CSVs only
  // 4 ms rows against one per 20 ms (no SR: no mode changes or events in between).
  EXPECT_GT(fs::file_size(dir_ / "f" / "trace.csv"), 4 * fs::file_size(dir_ / "c" / "trace.csv"));
}

TEST_F(FiguresCli, ReportFigures_MissingDir_Exit2NamingIt) {
  const auto r = run_rejuv(dir_, {"report", "figures", (dir_ / "nothing").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find((dir_ / "nothing").string() + ": error: not a directory"), std::string::npos) << r.err;
}

TEST_F(FiguresCli, ReportFigures_GarbageTrace_Exit2NamingTheFileAndLine) {
  write_run_dir(dir_, "garbage\n1,2,3\n", kControlHeader, kEventsHeader);
  const auto r = run_rejuv(dir_, {"report", "figures", dir_.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find((dir_ / "trace.csv").string() + ":1:1: error: expected a header"), std::string::npos) << r.err;
}

TEST_F(FiguresCli, ReportFigures_MissingEvents_Exit2NamingIt) {
  write_run_dir(dir_, kTraceHeader, kControlHeader, nullptr);
  const auto r = run_rejuv(dir_, {"report", "figures", dir_.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find((dir_ / "events.csv").string() + ": error: cannot read it"), std::string::npos) << r.err;
}

TEST_F(FiguresCli, ReportFigures_GarbageSummary_Exit2NamingIt) {
  write_run_dir(dir_, kTraceHeader, kControlHeader, kEventsHeader);
  std::ofstream(dir_ / "summary.json") << "{ not json";
  const auto r = run_rejuv(dir_, {"report", "figures", dir_.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("summary.json: error: not the RunSummary JSON"), std::string::npos) << r.err;
}

TEST_F(FiguresCli, TraceOrNoFiguresWithoutOut_Exit2) {
  const std::string graph = (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string();
  for (const char* command : {"sim", "run"}) {
    const auto r = run_rejuv(dir_, {command, graph, "--trace", "full"});
    EXPECT_EQ(r.exit_code, 2) << command;
    EXPECT_NE(r.err.find("--trace is the detail of --out's trace"), std::string::npos) << r.err;
    const auto bad = run_rejuv(dir_, {command, graph, "--out", (dir_ / "x").string(), "--trace", "some"});
    EXPECT_EQ(bad.exit_code, 2) << command;
    EXPECT_NE(bad.err.find("--trace: expected compact or full, got 'some'"), std::string::npos) << bad.err;
    const auto alone = run_rejuv(dir_, {command, graph, "--no-figures"});
    EXPECT_EQ(alone.exit_code, 2) << command;
    EXPECT_NE(alone.err.find("--no-figures goes with --out DIR"), std::string::npos) << alone.err;
  }
}

}  // namespace
