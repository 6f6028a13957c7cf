// The attack library in the model (docs/control.md "Attack library"): each kind through the engine on the real
// square (seed 1). Without SR it does harm; with SR the corruption is erased at every rollback and the vehicle
// stays inside the safety set through ≥ 45 attacked windows. Thresholds carry margins; no timing is asserted.
#include <gtest/gtest.h>

#include <filesystem>

#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::flight {
namespace {

const std::filesystem::path kSquare = std::filesystem::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt";

SimConfig config_for(AttackLaw law, SrSwitch sr) {
  auto loaded = launch::load_launch(kSquare);
  EXPECT_TRUE(loaded.has_value()) << (loaded ? "" : loaded.error().to_string());
  auto config = config_from_launch(*loaded, {.sr = sr});
  EXPECT_TRUE(config.has_value()) << (config ? "" : config.error().to_string());
  SimConfig c = config.value_or(SimConfig::defaults());
  c.attack.law = law;
  c.attack.magnitude = 0.0;  // the kind's default
  return c;
}

proto::RunSummary fly(AttackLaw law, SrSwitch sr) {
  auto s = run_simulation(config_for(law, sr));
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  return s.value_or(proto::RunSummary{});
}

class AttackLibrarySim : public ::testing::TestWithParam<AttackLaw> {};

TEST_P(AttackLibrarySim, WithoutSr_LeavesTheSafetySet) {
  const auto s = fly(GetParam(), SrSwitch::Off);
  EXPECT_EQ(s.attack_kind(), to_string(GetParam()));
  EXPECT_TRUE(s.left_safety_set()) << "max V " << s.max_v();
  EXPECT_FALSE(s.mission_completed());
  EXPECT_GT(s.d_max_m(), 1.0);  // the vehicle is more than 1 m off the square
}

TEST_P(AttackLibrarySim, WithSr_CompletesInsideTheSafetySetOverManyWindows) {
  const auto s = fly(GetParam(), SrSwitch::On);
  EXPECT_TRUE(s.mission_completed());
  EXPECT_GE(s.attacks(), 45U);
  EXPECT_LT(s.max_v(), 0.7);  // margin: the safety set is V < 1
  EXPECT_LT(s.d_max_m(), 0.5);
}

INSTANTIATE_TEST_SUITE_P(Kinds, AttackLibrarySim, ::testing::ValuesIn(kAllAttackLaws),
                         [](const ::testing::TestParamInfo<AttackLaw>& param_info) {
                           std::string name(to_string(param_info.param));
                           std::erase(name, '_');
                           return name;
                         });

// The corruption lives in the image: right after a rollback the published estimate is the filter's again.
TEST(AttackLibrarySimEngine, EstimateShift_ErasedByEveryRollback) {
  auto sim = SrSimulation::create(config_for(AttackLaw::EstimateShift, SrSwitch::On));
  ASSERT_TRUE(sim.has_value()) << sim.error().to_string();
  SrMode last = sim->mode();
  int rollbacks_seen = 0;
  bool shifted_in_mc = false;
  while (sim->step() && rollbacks_seen < 5) {
    if (sim->mode() == SrMode::MC) {
      // The model's published x̂ carries the shift: against the truth, ‖x̂ − x‖_P is near m = 2.
      const double err = std::sqrt(sim->design().ellipsoid.V(sim->published_estimate(), sim->truth()));
      shifted_in_mc = shifted_in_mc || err > 1.5;
    }
    if (last == SrMode::RB && sim->mode() != SrMode::RB) {
      ++rollbacks_seen;
      const double err = std::sqrt(sim->design().ellipsoid.V(sim->published_estimate(), sim->truth()));
      EXPECT_LT(err, 1.0) << "after rollback " << rollbacks_seen;
    }
    last = sim->mode();
  }
  EXPECT_EQ(rollbacks_seen, 5);
  EXPECT_TRUE(shifted_in_mc);
}

}  // namespace
}  // namespace rejuv::flight
