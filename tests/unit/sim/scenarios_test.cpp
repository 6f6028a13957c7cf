// Scenarios (a)–(d) of the SR tuning through the engine on the real launch graph (§VI-C/D, Table I), and the
// engine's behaviour around a rollback. Thresholds carry margins; timings are never asserted.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::flight {
namespace {

const std::filesystem::path kSquare = std::filesystem::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt";

SimConfig square_config(SimOverrides overrides = {}) {
  auto loaded = launch::load_launch(kSquare);
  EXPECT_TRUE(loaded.has_value()) << (loaded ? "" : loaded.error().to_string());
  auto config = config_from_launch(*loaded, overrides);
  EXPECT_TRUE(config.has_value()) << (config ? "" : config.error().to_string());
  return *config;
}

proto::RunSummary run(SimOverrides overrides) {
  auto summary = run_simulation(square_config(overrides));
  EXPECT_TRUE(summary.has_value()) << (summary ? "" : summary.error().to_string());
  return *summary;
}

// The square's graph with `attacks` as its plan (the model ignores what is not a control attack).
SimConfig square_config_with_plan(const std::string& attacks) {
  std::ifstream in(kSquare);
  std::stringstream text;
  text << in.rdbuf();
  std::string t = text.str();
  const std::string control = "  attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }\n";
  const std::size_t at = t.find(control);
  EXPECT_NE(at, std::string::npos) << "the square's plan changed";
  if (at != std::string::npos) t.replace(at, control.size(), attacks);
  auto loaded = launch::parse_launch(t, kSquare);
  EXPECT_TRUE(loaded.has_value()) << (loaded ? "" : loaded.error().to_string());
  auto config = config_from_launch(*loaded, {});
  EXPECT_TRUE(config.has_value()) << (config ? "" : config.error().to_string());
  return config.value_or(SimConfig::defaults());
}

// A runtime attack (ESCAPE_HELPER on ekf2) is the runtime's business; the model flies without attack.
TEST(SimConfigFromLaunch, OnlyARuntimeAttack_ModelAttackOff) {
  const SimConfig c = square_config_with_plan("  attacks { kind: ESCAPE_HELPER service: \"ekf2\" }\n");
  EXPECT_EQ(c.attack.enabled, AttackSwitch::Off);
}
TEST(SimConfigFromLaunch, RuntimeAttackBesideTheControlAttack_ModelKeepsTheControlAttack) {
  const SimConfig c = square_config_with_plan(
      "  attacks { kind: ESCAPE_HELPER service: \"ekf2\" }\n"
      "  attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" start_s: 2 }\n");
  EXPECT_EQ(c.attack.enabled, AttackSwitch::On);
  EXPECT_DOUBLE_EQ(c.attack.start.count(), 2.0);
}

// (a) Table I, first row: the tracking algorithm alone follows the square closely.
TEST(SimScenario, NoSrNoAttack_CompletesWithinFiveCentimetres) {
  const auto s = run({.sr = SrSwitch::Off, .attack = AttackSwitch::Off});
  EXPECT_TRUE(s.mission_completed());
  EXPECT_LT(s.d_mean_m(), 0.05);
  EXPECT_FALSE(s.left_safety_set());
  EXPECT_EQ(s.rollbacks(), 0U);
}

// (b) §VI-D: SR keeps the vehicle inside the safety set through ≥ 45 consecutive worst-case attacks.
TEST(SimScenario, SrWithAttack_CompletesInsideSafetySetOverManyAttacks) {
  const auto s = run({.sr = SrSwitch::On, .attack = AttackSwitch::On});
  EXPECT_TRUE(s.mission_completed());
  EXPECT_GE(s.attacks(), 45U);
  EXPECT_LT(s.max_v(), 0.7);  // margin: the safety set is V < 1
  EXPECT_FALSE(s.left_safety_set());
}

// (c) The attack is real: without SR the same attack leaves the safety set.
TEST(SimScenario, NoSrWithAttack_LeavesSafetySet) {
  const auto s = run({.sr = SrSwitch::Off, .attack = AttackSwitch::On});
  EXPECT_TRUE(s.left_safety_set());
  EXPECT_GT(s.max_v(), 1.0);
  EXPECT_FALSE(s.mission_completed());
}

// (d) SR costs time but not the mission.
TEST(SimScenario, SrNoAttack_Completes) {
  const auto s = run({.sr = SrSwitch::On, .attack = AttackSwitch::Off});
  EXPECT_TRUE(s.mission_completed());
  EXPECT_FALSE(s.left_safety_set());
  EXPECT_GT(s.rollbacks(), 0U);
  EXPECT_EQ(s.attacks(), 0U);
}

TEST(SimScenario, SameSeed_SameSummary) {
  auto a = run({.seed = 7});
  auto b = run({.seed = 7});
  for (auto* s : {&a, &b}) {  // only the wall-clock fields may differ
    s->clear_wall_time_s();
    s->clear_realtime_factor();
  }
  EXPECT_EQ(a.SerializeAsString(), b.SerializeAsString());
}

TEST(SimScenario, DifferentSeed_DifferentRun) {
  const auto a = run({.seed = 1});
  const auto b = run({.seed = 2});
  EXPECT_NE(a.max_v(), b.max_v());
}

// Fig. 7: the longest gap between two actuator updates is the checkpoint's hold plus at most one control period.
TEST(SimScenario, SrRun_ControlGapIsTheCheckpointHold) {
  const SimConfig config = square_config({.sr = SrSwitch::On, .attack = AttackSwitch::Off});
  const auto s = run_simulation(config);
  ASSERT_TRUE(s.has_value());
  const double t_cp_ms = config.t_cp.count() * 1e3;
  const double period_ms = std::chrono::duration<double, std::milli>(config.sensors.gyro_period).count();
  EXPECT_GE(s->max_control_gap_ms(), t_cp_ms);
  EXPECT_LE(s->max_control_gap_ms(), t_cp_ms + period_ms + 1.0);
}

// Every MC window of an attacked SR run is attacked, and each is ended by a rollback.
TEST(SimScenario, SrWithAttack_EveryMcWindowAttackedAndRolledBack) {
  const auto s = run({.sr = SrSwitch::On, .attack = AttackSwitch::On});
  EXPECT_EQ(s.attacks(), s.checkpoints());
  EXPECT_GE(s.rollbacks() + 1, s.attacks());  // the last window may end with the mission
}

class EngineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto sim = SrSimulation::create(square_config({.sr = SrSwitch::On, .attack = AttackSwitch::On}));
    ASSERT_TRUE(sim.has_value()) << sim.error().to_string();
    sim_ = std::make_unique<SrSimulation>(std::move(*sim));
  }
  // Steps until `pred` holds (or the run ends); false if it never did.
  template <class Pred>
  bool step_until(Pred pred) {
    while (!pred()) {
      if (!sim_->step()) return false;
    }
    return true;
  }
  std::unique_ptr<SrSimulation> sim_;
};

TEST_F(EngineTest, Boot_StartsInSafetyControl) { EXPECT_EQ(sim_->mode(), SrMode::SC); }

TEST_F(EngineTest, Modes_FollowFigureOneOrder) {
  // Fig. 1: MC → RB → SC → update → CP → MC, collected over the first few cycles.
  std::vector<SrMode> seen{sim_->mode()};
  while (seen.size() < 16 && sim_->step()) {
    if (sim_->mode() != seen.back()) seen.push_back(sim_->mode());
  }
  const std::map<SrMode, SrMode> next{{SrMode::SC, SrMode::Update}, {SrMode::Update, SrMode::CP},
                                      {SrMode::CP, SrMode::MC},     {SrMode::MC, SrMode::RB},
                                      {SrMode::RB, SrMode::SC}};
  ASSERT_GE(seen.size(), 10U);
  for (std::size_t i = 0; i + 1 < seen.size(); ++i) {
    EXPECT_EQ(seen[i + 1], next.at(seen[i])) << "transition " << i;
  }
}

TEST_F(EngineTest, Rollback_RestoresTheCheckpointedSetpointAndEstimate) {
  ASSERT_TRUE(step_until([&] { return sim_->mode() == SrMode::CP; }));
  const StateVec x_sp_at_cp = sim_->setpoint();
  const StateVec x_hat_at_cp = sim_->estimate();
  ASSERT_TRUE(step_until([&] { return sim_->mode() == SrMode::MC; }));
  ASSERT_TRUE(step_until([&] { return sim_->mode() == SrMode::RB; }));
  // The live estimate has moved on during MC (the attack tilted the vehicle)...
  const auto distance = [](const StateVec& a, const StateVec& b) {
    return std::max((a.head<3>() - b.head<3>()).norm(), (a.segment<3>(idx::kAtt) - b.segment<3>(idx::kAtt)).norm());
  };
  EXPECT_GT(distance(sim_->estimate(), x_hat_at_cp), 5e-3);
  ASSERT_TRUE(step_until([&] { return sim_->mode() == SrMode::SC; }));
  // ...and the rollback brought back the software state of the checkpoint (at most one 4 ms IMU step has been
  // integrated since), while the plant kept its own state.
  EXPECT_EQ(sim_->setpoint(), x_sp_at_cp);
  EXPECT_LT(distance(sim_->estimate(), x_hat_at_cp), 1e-3);
  EXPECT_GT(distance(sim_->truth(), x_hat_at_cp), 5e-3);
}

TEST(SimTrace, Rows_OnePerControlPeriodWithModes) {
  SimConfig config = square_config({.sr = SrSwitch::On, .attack = AttackSwitch::On});
  config.timeout = Seconds{4.0};
  std::vector<TraceRow> rows;
  SimObservers observers;
  observers.trace = [&](const TraceRow& r) { rows.push_back(r); };
  ASSERT_TRUE(run_simulation(config, observers).has_value());
  ASSERT_GE(rows.size(), 1000U);
  for (std::size_t i = 1; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].t - rows[i - 1].t, config.sensors.gyro_period);
  }
  EXPECT_EQ(rows.front().mode, SrMode::SC);
}

TEST(SimConfigFromLaunch, Overrides_Applied) {
  const SimConfig c = square_config({.sr = SrSwitch::Off, .attack = AttackSwitch::Off, .seed = 42});
  EXPECT_EQ(c.sr, SrSwitch::Off);
  EXPECT_EQ(c.attack.enabled, AttackSwitch::Off);
  EXPECT_EQ(c.seed, 42U);
  EXPECT_EQ(c.waypoints.size(), 5U);
  EXPECT_DOUBLE_EQ(c.handler.rho_s, 0.0894);
}

TEST(SimConfigFromLaunch, FractionNotReachableByRotors_LocatedError) {
  // Write a copy of the square graph with Ū as wide as U: the rotors cannot produce its corners.
  std::ifstream in(kSquare);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  const std::string from = "restricted_limit_fraction: 0.003";
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "restricted_limit_fraction: 0.9");
  auto loaded = launch::parse_launch(text, kSquare);
  ASSERT_TRUE(loaded.has_value()) << loaded.error().to_string();
  const auto c = config_from_launch(*loaded, {});
  ASSERT_FALSE(c.has_value());
  EXPECT_EQ(c.error().kind, LoadErrorKind::Semantic);
  EXPECT_GT(c.error().where.line, 0);
  EXPECT_NE(c.error().message.find("rotor levels"), std::string::npos) << c.error().message;
  const std::size_t line_start = text.rfind('\n', text.find("restricted_limit_fraction: 0.9")) + 1;
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(line_start), '\n'));
  EXPECT_EQ(c.error().where.line, line);
}

}  // namespace
}  // namespace rejuv::flight
