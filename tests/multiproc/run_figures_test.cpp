// `rejuv run GRAPH --out DIR` as a user runs it: the real binary flies a few seconds of the
// square with SR under attack and writes the summary, the compact trace, the record of every control update
// (Fig. 7) and of every SR event (Fig. 8), and, with gnuplot, Figs. 7-10 and the safety figure as PNG and SVG.
// No timing is asserted.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "figures.hpp"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::count_of;
using rejuv::test_support::slurp;
namespace fs = std::filesystem;

class RunFigures : public rejuv::test_support::ScratchDirTest {
 protected:
  RunFigures() : ScratchDirTest("rejuv_run_figures_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }
};

TEST_F(RunFigures, RunOut_WritesTheRecordsAndTheFigures) {
  const fs::path out = dir_ / "run";
  const auto r = rejuv::test_support::run_rejuv(
      dir_, {"run", (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string(), "--duration", "9", "--domain",
             std::to_string(rejuv::test_support::kOwnDdsDomain), "--net-port", "0", "--out", out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string control = slurp(out / "control.csv");
  const std::string events = slurp(out / "events.csv");
  // A control update every 4 ms for 9 s of flight; at least one rollback (T_est = 3 s, T_MC = 0.3 s).
  EXPECT_GT(count_of(control, "\n"), 1000U);
  // Marked in simulated time (the interval the charge lengthened) and in real time (the one it happened in).
  EXPECT_GE(count_of(control, ",RB,\n") + count_of(control, ",RB,RB\n"), 1U) << events;
  EXPECT_GE(count_of(control, ",CP,\n") + count_of(control, ",CP,CP\n"), 1U) << events;
  EXPECT_GE(count_of(control, ",RB\n"), 1U) << events;
  EXPECT_GE(count_of(control, ",CP\n"), 1U) << events;
  EXPECT_GE(count_of(events, ",rollback,"), 1U);
  EXPECT_GE(count_of(events, ",checkpoint,"), 1U);
  EXPECT_EQ(count_of(events, ",timer_armed,"), count_of(events, ",checkpoint,"));  // one arm per committed generation
  EXPECT_NE(events.find(",mode,"), std::string::npos);
  EXPECT_NE(events.find("checkpoint_p"), std::string::npos);  // who asked, by name
  EXPECT_NE(slurp(out / "summary.json").find("control_interval_ms"), std::string::npos);
  if (!rejuv::cli::find_gnuplot()) GTEST_SKIP() << "no gnuplot: the CSVs only";
  for (const char* name : rejuv::cli::kFigures) {
    const fs::path png = out / (std::string(name) + ".png");
    ASSERT_TRUE(fs::exists(png)) << png;
    EXPECT_EQ(slurp(png).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << png;
    EXPECT_GT(fs::file_size(out / (std::string(name) + ".svg")), 0U) << name;
  }
}

}  // namespace
