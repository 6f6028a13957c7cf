// `rejuv sweep --runner run`: one short runtime cell (`rejuv run` as a child, its own DDS domain, CPU and
// port), stopped cleanly after its attacks, its record kept.
#include <gtest/gtest.h>
#include <google/protobuf/util/json_util.h>

#include <filesystem>

#include "../../rejuv_cli.hpp"
#include "sweep.pb.h"

namespace rejuv {
namespace {

namespace fs = std::filesystem;

class SweepRun : public test_support::ScratchDirTest {
 protected:
  SweepRun() : ScratchDirTest("rejuv_sweep_run_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }
};

TEST_F(SweepRun, OneRuntimeCell_StoppedAfterItsAttacks_ChargedThePapers) {
  const fs::path out = dir_ / "s";
  const auto r = test_support::run_rejuv(
      dir_, {"sweep", (test_support::kRepo / "launch" / "quad_square_paper.launch.pbtxt").string(), "--param",
             "sr.t_mc_s=0.3", "--attacks", "3", "--seeds", "1", "--runner", "run", "--charges", "paper", "--out",
             out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  proto::SweepReport report;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(test_support::slurp(out / "sweep.json"), &report).ok());
  ASSERT_EQ(report.cells_size(), 1);
  const proto::SweepCellResult& c = report.cells(0);
  EXPECT_EQ(c.runner(), "run");
  ASSERT_EQ(c.ok(), 1U) << c.error();
  const proto::RunSummary& s = c.records(0).summary();
  EXPECT_EQ(s.runner(), "run");
  EXPECT_TRUE(s.stopped_after_attacks());
  EXPECT_EQ(s.attacks(), 3U);
  EXPECT_FALSE(s.left_safety_set());
  // --charges paper: the runtime's lockstep charged the paper's 20 ms per checkpoint and 15 ms per rollback.
  EXPECT_EQ(s.charging().charge(), "model");
  EXPECT_DOUBLE_EQ(s.charging().checkpoint_charge_ms(), 20.0);
  EXPECT_DOUBLE_EQ(s.charging().rollback_charge_ms(), 15.0);
  EXPECT_TRUE(fs::exists(out / "fig11a.png"));
}

}  // namespace
}  // namespace rejuv
