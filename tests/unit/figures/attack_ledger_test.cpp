// The run summary's attacks by kind (tools/rejuv/attack_ledger.hpp) from a known sequence of steps, modes and
// security events: windows by the plan's rule, events and V attributed to the attack whose span holds them.
#include <gtest/gtest.h>

#include "attack_ledger.hpp"

namespace rejuv::cli {
namespace {

using namespace std::chrono_literals;

proto::Launch plan() {
  proto::Launch g;
  g.mutable_attack()->set_enabled(true);
  proto::Attack& forged = *g.mutable_attack()->add_attacks();
  forged.set_kind(proto::FORGED_SLOT);
  forged.set_service("a");
  forged.set_max_windows(1);
  proto::Attack& custom = *g.mutable_attack()->add_attacks();
  custom.set_kind(proto::CUSTOM);
  custom.set_service("b");
  return g;
}

std::optional<ServiceId> find(std::string_view name) {
  if (name == "a") return ServiceId{0};
  if (name == "b") return ServiceId{1};
  return std::nullopt;
}

rejuv_msg_SecurityEvent denial(std::uint32_t service) {
  rejuv_msg_SecurityEvent e{};
  e.service_id = service;
  e.kind = rejuv_msg_SECURITY_CAPABILITY_DENIAL;
  return e;
}

// One SR cycle of epoch e at t0: a secure interval, then an MC window.
void cycle(AttackLedger& l, std::uint32_t e, Nanos t0) {
  l.on_mode(SrMode::SC, Epoch{e});
  l.on_step(t0, SrMode::SC);
  l.on_mode(SrMode::MC, Epoch{e});
  l.on_step(t0 + 10ms, SrMode::MC);
}

TEST(AttackLedger, WindowsDenialsAndVByTheAttackWhoseSpanHoldsThem) {
  AttackLedger l(plan(), true, Rejuvenation::On, 1s, find);
  l.on_step(0ms, SrMode::SC);      // aligning: before start_s + the alignment
  l.on_security_event(denial(0));  // in no span
  cycle(l, 0, 1s);
  l.on_security_event(denial(0));
  l.on_security_event(denial(1));
  l.on_V(0.4);
  cycle(l, 1, 2s);  // FORGED_SLOT's span ends (max_windows 1); CUSTOM's next window begins
  l.on_security_event(denial(0));
  l.on_V(0.2);
  proto::RunSummary s;
  l.fill(s);
  ASSERT_EQ(s.attacks_by_kind_size(), 2);
  EXPECT_EQ(s.attacks_by_kind(0).kind(), "FORGED_SLOT");
  EXPECT_EQ(s.attacks_by_kind(0).windows_fired(), 1U);
  EXPECT_EQ(s.attacks_by_kind(0).denied(), 1U);
  EXPECT_DOUBLE_EQ(s.attacks_by_kind(0).max_v(), 0.4);
  EXPECT_EQ(s.attacks_by_kind(1).kind(), "CUSTOM");
  EXPECT_EQ(s.attacks_by_kind(1).windows_fired(), 2U);
  EXPECT_EQ(s.attacks_by_kind(1).denied(), 1U);
  EXPECT_DOUBLE_EQ(s.attacks_by_kind(1).max_v(), 0.4);
  EXPECT_FALSE(s.attacks_by_kind(1).left_safety_set());
}

TEST(AttackLedger, AttacksOff_NoRows) {
  AttackLedger l(plan(), false, Rejuvenation::On, 1s, find);
  cycle(l, 0, 1s);
  proto::RunSummary s;
  l.fill(s);
  EXPECT_EQ(s.attacks_by_kind_size(), 0);
}

}  // namespace
}  // namespace rejuv::cli
