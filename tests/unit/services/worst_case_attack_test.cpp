// lqr_control's attack hook (test builds only): the decision of the worst-case control attack of §VI-D and
// its corner of Ū, as the simulation's attacker.
#include <gtest/gtest.h>

#if defined(REJUV_ATTACK_HOOKS)

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/flight/attack.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/services/lqr_control/mission_control.hpp"
#include "rejuv/services/lqr_control/worst_case_attack.hpp"
#include "default_design_fixture.hpp"
#include "service_test_messages.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;
using testing::state_message;

TextParam texts(std::map<std::string, std::string, std::less<>> table) {
  return [table = std::move(table)](std::string_view name) {
    const auto it = table.find(name);
    return it == table.end() ? std::string{} : it->second;
  };
}

TEST(WorstCaseAttackPlan, Plan_AttackOff_IsNone) {
  const auto plan = worst_case_attack_plan(
      flight_io::Params::from_table({{"attack.enabled", 0}, {"attack.count", 0}}), texts({}));
  ASSERT_TRUE(plan);
  EXPECT_FALSE(plan->has_value());
}

TEST(WorstCaseAttackPlan, Plan_WorstCaseControlNamed_ReadsStartAndWindows) {
  const auto plan = worst_case_attack_plan(
      flight_io::Params::from_table({{"attack.enabled", 1},
                                     {"attack.count", 2},
                                     {"attack.1.start_s", 4.5},
                                     {"attack.1.max_windows", 3},
                                     {"sr.enabled", 1}}),
      texts({{"attack.0.kind", "OTHER_KIND"}, {"attack.1.kind", "WORST_CASE_CONTROL"}}));
  ASSERT_TRUE(plan) << plan.error().to_string();
  ASSERT_TRUE(plan->has_value());
  EXPECT_EQ((*plan)->start, Seconds{4.5});
  EXPECT_EQ((*plan)->max_windows, 3U);
  EXPECT_EQ((*plan)->sr, flight::SrSwitch::On);
}

TEST(WorstCaseAttackPlan, Plan_OnlyOtherKinds_IsNone) {
  const auto plan =
      worst_case_attack_plan(flight_io::Params::from_table({{"attack.enabled", 1}, {"attack.count", 1}}),
                             texts({{"attack.0.kind", "X"}}));
  ASSERT_TRUE(plan);
  EXPECT_FALSE(plan->has_value());
}

TEST(WorstCaseAttackPlan, Plan_FractionalMaxWindows_Refused) {
  const auto plan =
      worst_case_attack_plan(flight_io::Params::from_table(
                                 {{"attack.enabled", 1}, {"attack.count", 1}, {"attack.0.max_windows", 1.5}}),
                             texts({{"attack.0.kind", "WORST_CASE_CONTROL"}}));
  ASSERT_FALSE(plan);
  EXPECT_EQ(plan.error().where, "attack.0.max_windows");
}

class WorstCaseAttackTest : public testing::DefaultDesignTest {
 protected:
  // One SR cycle of lqr_control's life: the SEI of `epoch` (restored image + SC steps), the checkpoint (the
  // image kept for the next rollback) and the MC window. Returns whether the window was attacked.
  static bool cycle(WorstCaseAttack& image, Epoch epoch, Nanos sei_at, Nanos mc_at) {
    WorstCaseAttack live = image;  // the rollback restores the image of the last checkpoint
    EXPECT_FALSE(live.decide(sei_at, SrMode::SC, epoch));
    EXPECT_FALSE(live.decide(sei_at, SrMode::CP, epoch));
    image = live;  // checkpoint in CP
    const bool first = live.decide(mc_at, SrMode::MC, epoch);
    EXPECT_EQ(live.decide(mc_at + milliseconds{200}, SrMode::MC, epoch), first) << "decided once per window";
    return first;
  }
};

TEST_F(WorstCaseAttackTest, Decide_EveryWindow_AttacksEachMcWindowOnly) {
  WorstCaseAttack image({.start = Seconds{0}, .max_windows = 0, .sr = flight::SrSwitch::On}, *design_);
  for (std::uint32_t e = 0; e < 5; ++e) {
    const Nanos t = milliseconds{4000 * (e + 1)};
    EXPECT_TRUE(cycle(image, Epoch{e}, t, t + milliseconds{30})) << "epoch " << e;
  }
}

TEST_F(WorstCaseAttackTest, Decide_MaxWindowsTwo_CountsAcrossRollbacks) {
  WorstCaseAttack image({.start = Seconds{0}, .max_windows = 2, .sr = flight::SrSwitch::On}, *design_);
  std::vector<bool> attacked;
  for (std::uint32_t e = 0; e < 5; ++e) {
    const Nanos t = milliseconds{4000 * (e + 1)};
    attacked.push_back(cycle(image, Epoch{e}, t, t + milliseconds{30}));
  }
  EXPECT_EQ(attacked, (std::vector<bool>{true, true, false, false, false}))
      << "every rollback restores the hook's memory, yet only two windows are attacked";
}

TEST_F(WorstCaseAttackTest, Decide_StartLater_WindowsBeforeStartAreHonest) {
  WorstCaseAttack image({.start = Seconds{5.0}, .max_windows = 1, .sr = flight::SrSwitch::On}, *design_);
  EXPECT_FALSE(cycle(image, Epoch{0}, milliseconds{3000}, milliseconds{3030}));
  EXPECT_FALSE(cycle(image, Epoch{1}, milliseconds{4500}, milliseconds{4530}));
  EXPECT_TRUE(cycle(image, Epoch{2}, milliseconds{6000}, milliseconds{6030}))
      << "the first window after start";
  EXPECT_FALSE(cycle(image, Epoch{3}, milliseconds{8000}, milliseconds{8030})) << "max_windows = 1";
}

TEST_F(WorstCaseAttackTest, Decide_SafetyModes_NeverForged) {
  WorstCaseAttack attack({.start = Seconds{0}, .max_windows = 0, .sr = flight::SrSwitch::On}, *design_);
  for (const SrMode mode : {SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP}) {
    EXPECT_FALSE(attack.decide(milliseconds{10}, mode, Epoch{0})) << to_string(mode);
  }
}

TEST_F(WorstCaseAttackTest, Decide_WithoutSr_StartsAtStartAndStays) {
  WorstCaseAttack attack({.start = Seconds{1.0}, .max_windows = 1, .sr = flight::SrSwitch::Off}, *design_);
  EXPECT_FALSE(attack.decide(milliseconds{999}, SrMode::MC, Epoch{0}));
  EXPECT_TRUE(attack.decide(milliseconds{1000}, SrMode::MC, Epoch{0}));
  EXPECT_TRUE(attack.decide(milliseconds{60000}, SrMode::MC, Epoch{0}));
  EXPECT_EQ(attack.windows_attacked(), 1U);
}

TEST_F(WorstCaseAttackTest, Corner_IsTheSimulationsWorstCaseCornerOfUbar) {
  const WorstCaseAttack attack({.start = Seconds{0}, .max_windows = 0, .sr = flight::SrSwitch::On}, *design_);
  const flight::StateVec x_sp = flight::hover_setpoint({1, 0, -3}, 0);
  flight::StateVec x_hat = x_sp;
  x_hat[0] += 0.05;
  x_hat[4] -= 0.1;
  x_hat[6] += 0.02;
  const flight::InputVec u = attack.corner(x_hat, x_sp);
  EXPECT_EQ(u, flight::worst_case_corner(design_->restricted, design_->ellipsoid.P(), design_->continuous.B,
                                         flight::state_error(x_hat, x_sp)));
  for (Eigen::Index j = 0; j < flight::kInputDim; ++j) {
    EXPECT_TRUE(u[j] == design_->restricted.lo[j] || u[j] == design_->restricted.hi[j])
        << "a corner of Ū, axis " << j;
  }
}

TEST_F(WorstCaseAttackTest, Hook_InMissionControl_PublishesTheCornerInsteadOfTheHonestControls) {
  const flight::StateVec x_sp = flight::hover_setpoint({0, 0, -3}, 0);
  MissionControl control(*design_, x_sp);
  WorstCaseAttack attack({.start = Seconds{0}, .max_windows = 0, .sr = flight::SrSwitch::On}, *design_);
  ASSERT_FALSE(attack.decide(milliseconds{1}, SrMode::SC, Epoch{0}));  // the SEI before the window
  control.set_attack_hook(
      [&](const flight::StateVec& x_hat, const flight::StateVec& sp, const flight::InputVec&) {
        return attack.on_control(milliseconds{40}, SrMode::MC, Epoch{0}, x_hat, sp);
      });
  flight::StateVec x = x_sp;
  x[1] += 0.05;
  const auto message = state_message(x, milliseconds{40});
  const auto u = control.on_state(message, Epoch{0});
  ASSERT_TRUE(u && u->has_value());
  const auto decoded = flight_io::controls_from_message(**u);
  ASSERT_TRUE(decoded);
  const auto x_hat = flight_io::state_from_message(message);
  ASSERT_TRUE(x_hat);
  EXPECT_EQ(*decoded, attack.corner(*x_hat, x_sp));
  EXPECT_NE(*decoded, control.controller().control(*x_hat, x_sp)) << "not the honest controls";
}

}  // namespace
}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
