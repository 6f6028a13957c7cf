// The runtime attack plan (services/attacks/plan.hpp): parsing the attack.* boot params, and which windows
// the hooks attack (docs/design.md §9, §11).
#include <gtest/gtest.h>

#include <array>

#include <map>
#include <string>

#include "launch.pb.h"
#include "rejuv/attacks/law.hpp"
#include "rejuv/attacks/plan.hpp"
#include "rejuv/flight/attack_library.hpp"

namespace rejuv::attacks {
namespace {

using namespace std::chrono_literals;

struct Params {
  std::map<std::string, double> numbers;
  std::map<std::string, std::string> texts;
  [[nodiscard]] Result<RuntimeAttackPlan, PlanError> plan() const {
    return runtime_attack_plan(
        [this](std::string_view n) -> std::optional<double> {
          auto it = numbers.find(std::string(n));
          return it == numbers.end() ? std::nullopt : std::optional<double>(it->second);
        },
        [this](std::string_view n) {
          auto it = texts.find(std::string(n));
          return it == texts.end() ? std::string() : it->second;
        });
  }
};

Params two_attacks() {
  Params p;
  p.numbers = {{"attack.enabled", 1}, {"attack.count", 3}, {"attack.0.start_s", 0}, {"attack.0.max_windows", 0},
               {"attack.1.start_s", 2.5}, {"attack.1.max_windows", 4}, {"attack.2.start_s", 1}};
  p.texts = {{"attack.0.kind", "FLOOD_BROKER"}, {"attack.1.kind", "NETWORK_IN_SEI"},
             {"attack.2.kind", "WORST_CASE_CONTROL"}};
  return p;
}

TEST(AttackKindNames, SameNamesAndNumbersAsTheLaunchProto) {
  for (const AttackKind k : kAllAttackKinds) {
    EXPECT_EQ(to_string(k), proto::AttackKind_Name(static_cast<proto::AttackKind>(k)));
    EXPECT_EQ(attack_kind_from_name(to_string(k)), k);
  }
  // Every runtime kind of the proto is here: all but the unset value, the attacks on the vehicle (the
  // controller's worst case and the attack library, flight::AttackLaw), CUSTOM (the service's own hook,
  // rejuv/sdk/attack_hook.hpp) and the replay attacks that sensors carries out itself
  // (services/sensors/src/replay_attack.cpp), which are not runtime attacks.
  constexpr std::array kSensorsOwn{"SLOW_REPLAY", "LYING_REPLAY"};
  EXPECT_EQ(kAllAttackKinds.size(), static_cast<std::size_t>(proto::AttackKind_MAX) - flight::kAllAttackLaws.size() -
                                        1 - kSensorsOwn.size());
  for (const char* own : kSensorsOwn) {
    proto::AttackKind number{};
    EXPECT_TRUE(proto::AttackKind_Parse(own, &number)) << own;
    EXPECT_EQ(attack_kind_from_name(own), std::nullopt) << own;
  }
  EXPECT_EQ(attack_kind_from_name("CUSTOM"), std::nullopt);
  for (const flight::AttackLaw law : flight::kAllAttackLaws) {
    EXPECT_EQ(attack_kind_from_name(flight::to_string(law)), std::nullopt) << flight::to_string(law);
    EXPECT_EQ(proto::AttackKind_Name(static_cast<proto::AttackKind>(flight::proto_number(law))), flight::to_string(law));
  }
}

TEST(RuntimeAttackPlan, Custom_NotARuntimeAttackAndNoError) {
  Params p;
  p.numbers = {{"attack.enabled", 1}, {"attack.count", 1}, {"attack.0.max_windows", 2}};
  p.texts = {{"attack.0.kind", "CUSTOM"}};
  auto plan = p.plan();
  ASSERT_TRUE(plan.has_value()) << plan.error().to_string();
  EXPECT_TRUE(plan->attacks.empty());
}

TEST(RuntimeAttackPlan, AttacksOff_NoAttacks) {
  Params p = two_attacks();
  p.numbers["attack.enabled"] = 0;
  auto plan = p.plan();
  ASSERT_TRUE(plan.has_value());
  EXPECT_TRUE(plan->attacks.empty());
}

TEST(RuntimeAttackPlan, NoParams_NoAttacksAndSrOn) {
  auto plan = Params{}.plan();
  ASSERT_TRUE(plan.has_value());
  EXPECT_TRUE(plan->attacks.empty());
  EXPECT_EQ(plan->sr, Rejuvenation::On);
}

TEST(RuntimeAttackPlan, RuntimeKindsInOrder_ControllerAttackSkipped) {
  auto plan = two_attacks().plan();
  ASSERT_TRUE(plan.has_value()) << plan.error().to_string();
  ASSERT_EQ(plan->attacks.size(), 2U);
  EXPECT_EQ(plan->attacks[0].kind, AttackKind::FloodBroker);
  EXPECT_EQ(plan->attacks[0].max_windows, 0U);
  EXPECT_EQ(plan->attacks[1].kind, AttackKind::NetworkInSei);
  EXPECT_DOUBLE_EQ(plan->attacks[1].start.count(), 2.5);
  EXPECT_EQ(plan->attacks[1].max_windows, 4U);
}

// ESCAPE_HELPER is carried out once, at boot; its target port is the service param escape_port.
TEST(RuntimeAttackPlan, EscapeHelper_OnceAtBootWithTheDefaultPort) {
  Params p;
  p.numbers = {{"attack.enabled", 1}, {"attack.count", 1}};
  p.texts = {{"attack.0.kind", "ESCAPE_HELPER"}};
  auto plan = p.plan();
  ASSERT_TRUE(plan.has_value()) << plan.error().to_string();
  ASSERT_EQ(plan->attacks.size(), 1U);
  EXPECT_EQ(plan->attacks[0].kind, AttackKind::EscapeHelper);
  EXPECT_EQ(occasion_of(AttackKind::EscapeHelper), Occasion::OnceAtBoot);
  EXPECT_EQ(occasion_of(AttackKind::OpenSocket), Occasion::EveryWindow);
  EXPECT_EQ(plan->escape_port, kDefaultEscapePort);
}
TEST(RuntimeAttackPlan, EscapePortParam_Used) {
  Params p = two_attacks();
  p.numbers["escape_port"] = 40123;
  auto plan = p.plan();
  ASSERT_TRUE(plan.has_value()) << plan.error().to_string();
  EXPECT_EQ(plan->escape_port, 40123);
}
TEST(RuntimeAttackPlan, EscapePortNotAPort_ErrorNamesTheParam) {
  for (const double bad : {0.0, 65536.0, 12.5, -1.0}) {
    Params p = two_attacks();
    p.numbers["escape_port"] = bad;
    auto plan = p.plan();
    ASSERT_FALSE(plan.has_value()) << bad;
    EXPECT_EQ(plan.error().param, "escape_port");
  }
}

TEST(RuntimeAttackPlan, SrOff_FromTheParams) {
  Params p = two_attacks();
  p.numbers["sr.enabled"] = 0;
  EXPECT_EQ(p.plan()->sr, Rejuvenation::Off);
}

TEST(RuntimeAttackPlan, UnknownKind_Error) {
  Params p = two_attacks();
  p.texts["attack.1.kind"] = "STEAL_KEYS";
  auto plan = p.plan();
  ASSERT_FALSE(plan.has_value());
  EXPECT_EQ(plan.error().param, "attack.1.kind");
}

TEST(RuntimeAttackPlan, NegativeStart_Error) {
  Params p = two_attacks();
  p.numbers["attack.0.start_s"] = -1;
  auto plan = p.plan();
  ASSERT_FALSE(plan.has_value());
  EXPECT_EQ(plan.error().param, "attack.0.start_s");
}

TEST(RuntimeAttackPlan, FractionalMaxWindows_Error) {
  Params p = two_attacks();
  p.numbers["attack.1.max_windows"] = 1.5;
  auto plan = p.plan();
  ASSERT_FALSE(plan.has_value());
  EXPECT_EQ(plan.error().param, "attack.1.max_windows");
}

TEST(RuntimeAttackPlan, BadCount_Error) {
  Params p = two_attacks();
  p.numbers["attack.count"] = -2;
  auto plan = p.plan();
  ASSERT_FALSE(plan.has_value());
  EXPECT_EQ(plan.error().param, "attack.count");
}

// One SR cycle per epoch: a secure interval, then an MC window (docs/design.md §8).
struct Tick {
  Nanos t;
  SrMode mode;
  std::uint32_t epoch;
};

int attacked(WindowClock& c, const std::vector<Tick>& ticks) {
  int n = 0;
  for (const Tick& k : ticks) n += c.begins(k.t, k.mode, Epoch{k.epoch}) ? 1 : 0;
  return n;
}

std::vector<Tick> cycles(int epochs, Nanos cycle = 1s) {
  std::vector<Tick> out;
  for (int e = 0; e < epochs; ++e) {
    const Nanos t0 = cycle * e;
    for (int i = 0; i < 3; ++i) out.push_back({t0 + i * 10ms, i == 0 ? SrMode::RB : SrMode::SC, static_cast<std::uint32_t>(e)});
    for (int i = 0; i < 5; ++i) out.push_back({t0 + 100ms + i * 10ms, SrMode::MC, static_cast<std::uint32_t>(e)});
  }
  return out;
}

TEST(WindowClock, EveryMcWindowOnce) {
  WindowClock c({.kind = AttackKind::ForgedSlot, .start = Seconds{0}, .max_windows = 0}, Rejuvenation::On);
  EXPECT_EQ(attacked(c, cycles(4)), 4);
}

TEST(WindowClock, SecureIntervalAttack_EverySecureIntervalOnce) {
  WindowClock c({.kind = AttackKind::NetworkInSei, .start = Seconds{0}, .max_windows = 0}, Rejuvenation::On);
  const auto ticks = cycles(3);
  for (const Tick& k : ticks) {
    const bool begins = c.begins(k.t, k.mode, Epoch{k.epoch});
    if (begins) {
      EXPECT_NE(k.mode, SrMode::MC);
    }
  }
  WindowClock again({.kind = AttackKind::NetworkInSei, .start = Seconds{0}, .max_windows = 0}, Rejuvenation::On);
  EXPECT_EQ(attacked(again, ticks), 3);
}

TEST(WindowClock, MaxWindowsAndStart) {
  WindowClock c({.kind = AttackKind::FloodBroker, .start = Seconds{1.5}, .max_windows = 2}, Rejuvenation::On);
  // Windows of epochs 2 and 3 (the first secure interval at or after 1.5 s is that of epoch 2).
  int n = 0;
  for (const Tick& k : cycles(6)) {
    if (c.begins(k.t, k.mode, Epoch{k.epoch})) {
      EXPECT_GE(k.epoch, 2U);
      EXPECT_LE(k.epoch, 3U);
      EXPECT_EQ(c.ordinal(), k.epoch - 2U);
      ++n;
    }
  }
  EXPECT_EQ(n, 2);
}

TEST(WindowClock, RestoredImage_KnowsItsWindowFromTheEpoch) {
  // The image is the clock as it was at the checkpoint (end of the secure interval of epoch 0); restored into
  // epoch 1, then 2, it attacks each MC window once and stops after max_windows, remembering nothing.
  WindowClock live({.kind = AttackKind::OpenSocket, .start = Seconds{0}, .max_windows = 2}, Rejuvenation::On);
  EXPECT_FALSE(live.begins(0ms, SrMode::SC, Epoch{0}));
  const WindowClock image = live;  // checkpoint (CP)
  EXPECT_TRUE(live.begins(50ms, SrMode::MC, Epoch{0}));
  for (std::uint32_t e = 1; e <= 3; ++e) {
    WindowClock restored = image;  // the rollback wipes what the live process learned
    EXPECT_FALSE(restored.begins(Nanos{e * 1'000'000'000LL}, SrMode::RB, Epoch{e}));
    EXPECT_EQ(restored.begins(Nanos{e * 1'000'000'000LL + 50'000'000}, SrMode::MC, Epoch{e}), e < 2) << "epoch " << e;
  }
}

TEST(WindowClock, SrOff_OneEndlessWindowAttackedOnce) {
  WindowClock c({.kind = AttackKind::WriteLimits, .start = Seconds{0.5}, .max_windows = 0}, Rejuvenation::Off);
  EXPECT_FALSE(c.begins(100ms, SrMode::MC, Epoch{0}));
  EXPECT_TRUE(c.begins(600ms, SrMode::MC, Epoch{0}));
  EXPECT_FALSE(c.begins(700ms, SrMode::MC, Epoch{0}));
}

}  // namespace
}  // namespace rejuv::attacks

// The attack library's runtime plan and window (law.hpp): the plan picks the first attack of the service's
// laws with the kind's default size; τ runs from the first step of each attacked MC window and ends with it.
namespace rejuv::attacks {
namespace {

Result<std::optional<LawAttack>, PlanError> law_plan(const std::map<std::string, double>& numbers,
                                                     const std::map<std::string, std::string>& texts) {
  return law_attack_plan(
      [&](std::string_view n) -> std::optional<double> {
        auto it = numbers.find(std::string(n));
        return it == numbers.end() ? std::nullopt : std::optional<double>(it->second);
      },
      [&](std::string_view n) {
        auto it = texts.find(std::string(n));
        return it == texts.end() ? std::string() : it->second;
      },
      {flight::AttackLaw::EstimateShift, flight::AttackLaw::EstimateDrift});
}

TEST(LawAttackPlan, FirstOfTheServiceLawsWithDefaultSize_BadMagnitudeRefused) {
  const std::map<std::string, std::string> texts{{"attack.0.kind", "FLOOD_BROKER"},
                                                 {"attack.1.kind", "ESTIMATE_DRIFT"}};
  std::map<std::string, double> numbers{{"attack.enabled", 1}, {"attack.count", 2}, {"attack.1.start_s", 3}};
  auto plan = law_plan(numbers, texts);
  ASSERT_TRUE(plan.has_value()) << plan.error().to_string();
  ASSERT_TRUE(plan->has_value());
  EXPECT_EQ((*plan)->law, flight::AttackLaw::EstimateDrift);
  EXPECT_DOUBLE_EQ((*plan)->magnitude, flight::default_magnitude(flight::AttackLaw::EstimateDrift));
  EXPECT_DOUBLE_EQ((*plan)->start.count(), 3.0);
  numbers["attack.1.magnitude"] = -1;
  auto bad = law_plan(numbers, texts);
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().param, "attack.1.magnitude");
  numbers["attack.enabled"] = 0;
  auto off = law_plan(numbers, texts);
  ASSERT_TRUE(off.has_value());
  EXPECT_FALSE(off->has_value());
}

TEST(LawWindow, TauFromEachAttackedWindowStart_NoneOutsideIt) {
  LawWindow w(LawAttack{.law = flight::AttackLaw::EstimateDrift, .start = Seconds{0}, .sr = Rejuvenation::On});
  const auto ms = [](int v) { return Nanos{std::chrono::milliseconds{v}}; };
  EXPECT_FALSE(w.tau(ms(0), SrMode::SC, Epoch{1}).has_value());  // the SEI records the first epoch
  const auto t0 = w.tau(ms(100), SrMode::MC, Epoch{1});
  ASSERT_TRUE(t0.has_value());
  EXPECT_TRUE(w.began_now());
  EXPECT_DOUBLE_EQ(t0->count(), 0.0);
  const auto t1 = w.tau(ms(300), SrMode::MC, Epoch{1});
  ASSERT_TRUE(t1.has_value());
  EXPECT_FALSE(w.began_now());
  EXPECT_NEAR(t1->count(), 0.2, 1e-12);
  EXPECT_FALSE(w.tau(ms(400), SrMode::RB, Epoch{1}).has_value());
  EXPECT_FALSE(w.tau(ms(500), SrMode::SC, Epoch{2}).has_value());
  const auto t2 = w.tau(ms(4000), SrMode::MC, Epoch{2});  // the next window starts τ at 0 again
  ASSERT_TRUE(t2.has_value());
  EXPECT_DOUBLE_EQ(t2->count(), 0.0);
}

TEST(LawWindow, WithoutSr_OneEndlessWindowFromStart) {
  LawWindow w(LawAttack{.law = flight::AttackLaw::SetpointShift, .start = Seconds{1}, .sr = Rejuvenation::Off});
  const auto s = [](double v) { return to_nanos(Seconds{v}); };
  EXPECT_FALSE(w.tau(s(0.5), SrMode::MC, Epoch{0}).has_value());
  ASSERT_TRUE(w.tau(s(1.0), SrMode::MC, Epoch{0}).has_value());
  const auto later = w.tau(s(11.0), SrMode::MC, Epoch{0});
  ASSERT_TRUE(later.has_value());
  EXPECT_NEAR(later->count(), 10.0, 1e-9);
}

}  // namespace
}  // namespace rejuv::attacks
