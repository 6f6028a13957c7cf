// Every runtime attack of the catalogue (idl/launch.proto AttackKind 2…11; docs/design.md §11) carried
// out by a compromised service of a real graph, and denied or contained: real kernel, real service processes
// (tests/security/services/attack_service.cpp with the hooks of services/attacks), real channels and seccomp
// filters, lockstep driven by the test (TimeMaster::Manual), SR on. The attack plan is the launch text's
// `attack` section, so the path launch → boot params → hook is the one `rejuv run` uses.
//
// Each test checks the kernel's counters (the attempt was seen and refused) and the state the attack aimed at
// (no checkpoint taken, no timer armed, limits and persistent cell unchanged, actuator outputs only from the
// driver, the network unused, images alive, the flood bounded). No timing is asserted.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "graph_fixture.hpp"
#include "rejuv/attacks/plan.hpp"
#include "rejuv/channel/wire.hpp"
#include "security_launch.hpp"
#include "services/verdicts.hpp"

namespace rejuv::testing {
namespace {

using attacks::AttackKind;
namespace verdicts = test_services::verdicts;

constexpr double kForgedLimit = 1.0e6;       // attacks::kForgedLimit (hooks.hpp; not linked here)
constexpr std::uint64_t kForgedCell = 0xA7A7'A7A7'A7A7'A7A7ULL;  // attacks::kForgedPersistentByte × 8
constexpr std::uint32_t kFloodMessages = 10000;  // attacks::kFloodMessages

std::string attack_launch(AttackKind kind, const std::string& attacker,
                          const std::string& worker_extra = "") {
  return security_launch(
      {.worker_extra = worker_extra,
       .attack = "attack {\n  enabled: true\n  attacks { kind: " + std::string(attacks::to_string(kind)) +
                 " service: \"" + attacker + "\" }\n}\n"});
}

class Attacks : public ::testing::Test {
 protected:
  void start(AttackKind kind, const std::string& attacker) {
    kind_ = kind;
    attacker_ = attacker;
    start_graph(attack_launch(kind, attacker));
  }
  void start_graph(const std::string& text) {
    auto loaded = launch::parse_launch(
        text, std::filesystem::path(REJUV_SOURCE_DIR) / "tests/security/graphs/attacks.launch.pbtxt");
    ASSERT_TRUE(loaded.has_value()) << loaded.error().to_string();
    kernel::KernelOptions o = test_options();
    o.log = std::getenv("REJUV_TEST_LOG") != nullptr ? stderr : nullptr;  // quiet unless asked
    o.verbose = o.log != nullptr;
    auto k = kernel::Kernel::create(std::move(*loaded), o, &recorder_);
    ASSERT_TRUE(k.has_value()) << k.error().to_string() << "\n" << ::testing::PrintToString(k.error().findings);
    k_ = std::move(*k);
    auto booted = k_->boot();
    ASSERT_TRUE(booted.has_value()) << booted.error().to_string();
  }
  ServiceId id(std::string_view name) const { return *k_->find_service(name); }
  [[nodiscard]] ::testing::AssertionResult step_until_rollbacks(std::uint64_t n, int limit = 600) {
    return testing::step_until_rollbacks(*k_, n, limit);
  }
  // The reports of type T (services/verdicts.hpp) that `who` published on `verdicts`, in order.
  template <class T>
  std::vector<T> reports(std::string_view who) const {
    std::vector<T> out;
    for (const Seen* s : recorder_.on("verdicts")) {
      if (s->publisher != id(who)) continue;
      if (auto r = verdicts::decode<T>(Recorder::as<rejuv_msg_SensorBaro>(*s))) out.push_back(*r);
    }
    return out;
  }
  // The attacker's reports of its attempts.
  std::vector<verdicts::AttackAttempt> attempts() const {
    std::vector<verdicts::AttackAttempt> out;
    for (const Seen* s : recorder_.on("verdicts")) {
      if (s->publisher != id(attacker_)) continue;
      const auto r =
          verdicts::decode_attempt(Recorder::as<rejuv_msg_SensorBaro>(*s), static_cast<double>(kind_));
      if (r) out.push_back(*r);
    }
    return out;
  }
  std::uint64_t denials_of(std::string_view who, cap::Operation op) const {
    std::uint64_t n = 0;
    for (const cap::CapError e : cap::kAllCapErrors) n += k_->caps().denials().at(id(who), e, op);
    return n;
  }

  // What no attack may change (docs/design.md §3, §7, §8): only the honest SR cycle checkpointed and armed the timer,
  // the limits and the cell hold what `rejuv` wrote, motor outputs come from the driver alone, the network
  // sent nothing, every image is alive and the run goes on.
  void expect_runtime_intact() const {
    const kernel::SrStats& sr = k_->sr_stats();
    const std::size_t taken = reports<verdicts::CheckpointTaken>("rejuv").size();
    EXPECT_EQ(sr.checkpoints, taken) << "a checkpoint the SR cycle did not take";
    EXPECT_EQ(sr.timer_arms, taken) << "a timer arm the SR cycle did not make";
    EXPECT_EQ(sr.timer_arm_refused, 0U);
    EXPECT_EQ(sr.fallbacks, 0U);
    EXPECT_EQ(sr.cold_restarts, 0U);
    const auto limits = reports<verdicts::LimitsRead>("driver");
    EXPECT_FALSE(limits.empty());
    for (const auto& l : limits) EXPECT_EQ(l.first_limit, 0.3) << "the limits the driver applies changed";
    const auto cells = reports<verdicts::CellRead>("rejuv");
    EXPECT_FALSE(cells.empty());
    for (const auto& c : cells) EXPECT_LT(c.cell, 1000.0) << "the persistent cell was overwritten";
    const auto outputs = recorder_.on("actuator_outputs");
    EXPECT_FALSE(outputs.empty());
    for (const Seen* s : outputs) {
      EXPECT_EQ(s->publisher, id("driver"));
      EXPECT_EQ(Recorder::as<rejuv_msg_ActuatorOutputs>(*s).motor[0], 0.5);
    }
    EXPECT_EQ(k_->net_stats().sent, 0U);
    for (const char* who : {"rejuv", "worker", "link"}) {
      for (const int pid : k_->image_pids(id(who))) EXPECT_EQ(::kill(pid, 0), 0) << who << " image " << pid;
    }
    for (const char* who : {"rejuv", "worker", "link", "driver"}) EXPECT_TRUE(k_->stats(id(who)).alive) << who;
    EXPECT_FALSE(k_->stop_reason().has_value());
  }
  // Every attempt that got an answer was refused with a capability error (Reply.error = 1 + CapError).
  void expect_all_denied(std::size_t at_least) const {
    const auto a = attempts();
    EXPECT_GE(a.size(), at_least);
    for (const auto& r : a) {
      EXPECT_NE(r.code, 0.0) << "accepted on slot " << r.target;
      if (r.code > 0) {
        EXPECT_LE(r.code, static_cast<double>(cap::kAllCapErrors.size())) << "not a denial";
      }
    }
  }

  // The forbidden calls the kernel refused are the ones the attack meant to make (and at least one of them),
  // not a call of the hook's own machinery.
  static void expect_refused_only(const kernel::ServiceStats& s, std::initializer_list<std::string_view> meant) {
    EXPECT_FALSE(s.calls_refused.empty());
    for (const auto& [call, n] : s.calls_refused) {
      EXPECT_NE(std::find(meant.begin(), meant.end(), call), meant.end()) << call << " refused " << n << " time(s)";
    }
  }

  AttackKind kind_ = AttackKind::ForgedSlot;
  std::string attacker_;
  Recorder recorder_;
  std::unique_ptr<kernel::Kernel> k_;
};

// CUSTOM (rejuv/sdk/attack_hook.hpp): the windows the plan decides reach the service's own hook — in MC only,
// max_windows of them from start_s on, with the plan's magnitude — and the runtime is untouched (the hook
// itself does nothing the author did not write).
TEST_F(Attacks, Custom_TheSdkHookSeesThePlansWindowsInMcOnly) {
  attacker_ = "worker";
  ASSERT_NO_FATAL_FAILURE(
      start_graph(security_launch({.worker_extra = "",
                                   .attack = "attack {\n  enabled: true\n  attacks { kind: CUSTOM service: "
                                             "\"worker\" max_windows: 2 magnitude: 3 }\n}\n"})));
  ASSERT_TRUE(step_until_rollbacks(5));
  const double mc = static_cast<double>(index_of(SrMode::MC));
  const auto windows = reports<verdicts::CustomWindow>("worker");
  ASSERT_EQ(windows.size(), 2U) << "max_windows of the 5 MC windows flown";
  for (const auto& w : windows) {
    EXPECT_EQ(w.mode, mc) << "a window began outside MC";
    EXPECT_EQ(w.magnitude, 3.0);
  }
  const auto active = reports<verdicts::CustomActive>("worker");
  ASSERT_FALSE(active.empty()) << "the hook never said a window was in force";
  std::vector<double> epochs;
  for (const auto& a : active) {
    EXPECT_EQ(a.mode, mc) << "in force outside MC (epoch " << a.epoch << ")";
    if (std::find(epochs.begin(), epochs.end(), a.epoch) == epochs.end()) epochs.push_back(a.epoch);
  }
  EXPECT_EQ(epochs.size(), 2U) << "in force in exactly the two attacked windows";
  for (const char* who : {"rejuv", "link", "driver"}) {
    EXPECT_TRUE(reports<verdicts::CustomWindow>(who).empty()) << who << " is not named by the plan";
  }
  EXPECT_EQ(k_->stats(id("worker")).denials, 0U);
  expect_runtime_intact();
}

TEST_F(Attacks, InvokeCheckpoint_InMc_DeniedAndNoCheckpointTaken) {
  ASSERT_NO_FATAL_FAILURE(
      start(AttackKind::InvokeCheckpoint, "rejuv"));  // the rejuvenation service itself, compromised in MC
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_all_denied(2 * 4);
  EXPECT_GE(denials_of("rejuv", cap::Operation::CheckpointCreate), 2U * 4U);
  EXPECT_GE(denials_of("rejuv", cap::Operation::CheckpointRollback), 2U * 4U);
  EXPECT_EQ(k_->sr_stats().rollbacks, k_->sr_stats().timer_rollbacks) << "a rollback the timer did not fire";
  expect_runtime_intact();
}

TEST_F(Attacks, ArmTimer_InMc_DeniedAndTheTimerArmedOncePerEpoch) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::ArmTimer, "rejuv"));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_all_denied(2 * 4);
  EXPECT_GE(denials_of("rejuv", cap::Operation::TimerArm), 2U * 4U);
  EXPECT_EQ(k_->sr_stats().rollbacks, k_->sr_stats().timer_rollbacks);
  expect_runtime_intact();
}

TEST_F(Attacks, WriteLimits_InMc_DeniedAndTheDriverKeepsTheRestrictedLimits) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::WriteLimits, "rejuv"));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_all_denied(2 * 4);
  EXPECT_GE(denials_of("rejuv", cap::Operation::LimitsWrite), 2U * 4U);
  for (const auto& l : reports<verdicts::LimitsRead>("driver")) EXPECT_NE(l.first_limit, kForgedLimit);
  expect_runtime_intact();
}

TEST_F(Attacks, PublishActuatorOutputs_NoOutputButTheDriversAndEveryPublishRefused) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::PublishActuatorOutputs, "worker"));
  ASSERT_TRUE(step_until_rollbacks(3));
  const auto a = attempts();
  ASSERT_GE(a.size(), 2U * 3U);  // numbers, verdicts and never-held slots, per window
  // Refused by the cap check (slots it does not hold, or without Write) or, on its own topics, by size.
  const std::uint64_t refused = denials_of("worker", cap::Operation::Publish) + k_->stats(id("worker")).wrong_size;
  EXPECT_GE(refused, a.size());
  EXPECT_GE(k_->stats(id("worker")).wrong_size, 2U);  // numbers and verdicts: an ActuatorOutputs does not fit
  expect_runtime_intact();
}

TEST_F(Attacks, WritePersistent_InMc_DeniedAndTheCellKeepsItsValue) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::WritePersistent, "rejuv"));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_all_denied(2 * 4);
  EXPECT_GE(denials_of("rejuv", cap::Operation::PersistentWrite), 2U * 4U);
  const auto cells = reports<verdicts::CellRead>("rejuv");
  for (const auto& c : cells) EXPECT_NE(c.cell, static_cast<double>(kForgedCell));
  // The cell counts the SR cycles (read before each write): 0, 1, 2, … with no forged value in between.
  for (std::size_t i = 0; i < cells.size(); ++i) EXPECT_LE(cells[i].cell, static_cast<double>(i));
  expect_runtime_intact();
}

TEST_F(Attacks, ForgedSlot_EveryRequestOnASlotNeverHeldDenied) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::ForgedSlot, "worker"));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_all_denied(2 * 4 * 5);
  const cap::DenialCounters& d = k_->caps().denials();
  const ServiceId w = id("worker");
  std::uint64_t empty = 0;
  std::uint64_t out_of_range = 0;
  for (const cap::Operation op : cap::kAllOperations) {
    empty += d.at(w, cap::CapError::EmptySlot, op);
    out_of_range += d.at(w, cap::CapError::SlotOutOfRange, op);
  }
  EXPECT_GE(out_of_range, 2U * 2U * 6U);  // two slots beyond any CSpace, six requests each, per window
  EXPECT_GT(empty, 0U);
  EXPECT_GT(d.at(w, cap::CapError::SlotOutOfRange, cap::Operation::Publish), 0U);
  expect_runtime_intact();
}

TEST_F(Attacks, NetworkInSei_NetSendDeniedAndNothingSent) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::NetworkInSei, "link"));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_all_denied(3);
  // Its own Network cap is empty outside MC: the gate never sees the datagram.
  EXPECT_GE(denials_of("link", cap::Operation::NetSend), 3U);
  EXPECT_EQ(k_->net_stats().sent, 0U);
  EXPECT_GE(k_->net_stats().send_refused, 3U);
  expect_runtime_intact();
}

TEST_F(Attacks, KillImage_TheSandboxEndsTheAttackerAndTheRollbackContainsIt) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::KillImage, "worker"));
  const int test_pid = ::getpid();
  ASSERT_TRUE(step_until_rollbacks(4));
  // Each attacked window the first forbidden call (kill, ptrace, process_vm_readv, pidfd_open) ended the
  // worker by SIGSYS: counted, and the worker was rolled back with the graph — no call ever returned.
  EXPECT_TRUE(attempts().empty()) << "a forbidden system call returned";
  EXPECT_GE(k_->stats(id("worker")).sandbox_violations, 2U);
  expect_refused_only(k_->stats(id("worker")), {"kill", "tgkill", "ptrace", "process_vm_readv", "pidfd_open"});
  EXPECT_LT(k_->sr_stats().timer_rollbacks, k_->sr_stats().rollbacks) << "no rollback by the violation";
  EXPECT_EQ(::getpid(), test_pid);  // the kernel (this process) is untouched
  expect_runtime_intact();
}

TEST_F(Attacks, OpenSocket_TheSandboxEndsTheAttackerAndTheRollbackContainsIt) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::OpenSocket, "worker"));
  ASSERT_TRUE(step_until_rollbacks(4));
  EXPECT_TRUE(attempts().empty()) << "socket() or socketpair() returned";
  EXPECT_GE(k_->stats(id("worker")).sandbox_violations, 2U);
  expect_refused_only(k_->stats(id("worker")), {"socket", "socketpair"});
  EXPECT_LT(k_->sr_stats().timer_rollbacks, k_->sr_stats().rollbacks);
  expect_runtime_intact();
}

TEST_F(Attacks, FloodBroker_BoundedPerStepAndTheReaderGetsOrCountsEveryMessage) {
  // The worker's publication budget at its most (the next test has the default): the step bound alone.
  kind_ = AttackKind::FloodBroker;
  attacker_ = "worker";
  ASSERT_NO_FATAL_FAILURE(start_graph(
      attack_launch(AttackKind::FloodBroker, "worker", "  limits { max_publications_per_s: 1000000 }\n")));
  ASSERT_TRUE(step_until_rollbacks(3));
  const kernel::ServiceStats worker = k_->stats(id("worker"));
  // Each flood is cut at the per-step bound: at least kFloodMessages - 4096 dropped per attacked window.
  EXPECT_GE(worker.flood_dropped, 2U * (kFloodMessages - 4096U));
  // The driver (never rolled back) reads `numbers` with a ring of 64. Whether it keeps up depends on how
  // much its channel holds (deliveries travel packed, up to 64 per datagram): every message of the floods
  // that passed the bound was delivered to it or counted lost (ring overrun), never silently gone, and it
  // kept its footing.
  const kernel::ServiceStats driver = k_->stats(id("driver"));
  EXPECT_GE(driver.delivered + driver.lost, 2U * 4096U);
  EXPECT_FALSE(driver.hung);
  expect_runtime_intact();
}

// (The SecurityEvent of the budget: tests/security/flood_attack_test.cpp, whose policy has the topic.)
TEST_F(Attacks, FloodBroker_OverThePublicationBudget_DroppedAndCountedForTheFlooderOnly) {
  ASSERT_NO_FATAL_FAILURE(start(AttackKind::FloodBroker, "worker"));
  ASSERT_TRUE(step_until_rollbacks(3));
  const kernel::ServiceStats worker = k_->stats(id("worker"));
  // Of each 10000-message flood 4096 pass the step bound; the budget (2000/s, a burst of 2000) passes at most
  // what its bucket held: what was routed stays within 2000 per second of kernel time plus the burst.
  const double kernel_s = to_seconds(k_->now()).count();
  EXPECT_GT(worker.publications_over_budget, 0U);
  EXPECT_LE(worker.publishes, static_cast<std::uint64_t>(2000.0 * (kernel_s + 1.0)));
  // Nobody else lost a publication to a budget.
  for (const char* other : {"driver", "link", "rejuv"}) {
    if (const auto s = k_->find_service(other)) {
      EXPECT_EQ(k_->stats(*s).publications_over_budget, 0U) << other;
    }
  }
  expect_runtime_intact();
}

}  // namespace
}  // namespace rejuv::testing
