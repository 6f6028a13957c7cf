// The attack library on the multi-process runtime (docs/control.md "Attack library"): each
// kind flown by `rejuv run` on the square (seed 1) through the real kernel, services and plant, with the hook
// in the compromised service (ekf2, sensors, gen_set_point, lqr_control) — one test per kind, each two short
// missions: without SR the attack does harm (the vehicle leaves the safety set, max V >= 1, and the run stops
// when it is lost, V > 100), with SR the corruption is erased at every rollback and the vehicle stays inside
// (max V < 1) through the attacked windows of the flight. Asserted by effect; no timing.
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "summary.pb.h"

namespace {

namespace fs = std::filesystem;
using rejuv::test_support::kRepo;

// Seconds of flight: long enough for every kind to lose the vehicle without SR (the model: ≤ 16 s) and for
// several attacked MC windows with SR (one SR cycle ≈ 3.1 s on the square).
constexpr double kFlightNoSr = 20.0;
constexpr double kFlightSr = 16.0;

class AttackLibrary : public rejuv::test_support::ScratchDirTest {
 protected:
  AttackLibrary() : ScratchDirTest("rejuv_attack_library_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }

  struct Flight {
    int exit_code = -1;
    rejuv::proto::RunSummary summary;
    std::string err;
  };

  // `graph`: the square (the default) or a variant of it; `kind`: the --attack KIND, or "" to fly the graph's
  // plan.
  Flight fly(const std::string& kind, bool sr,
             const fs::path& graph = kRepo / "launch/quad_square_paper.launch.pbtxt", double seconds = 0) {
    const fs::path json =
        dir_ / ((kind.empty() ? graph.stem().string() : kind) + (sr ? "_sr" : "_nosr") + ".json");
    std::vector<std::string> args{"run",
                                  graph.string(),
                                  "--seed",
                                  "1",
                                  "--duration",
                                  std::to_string(seconds > 0 ? seconds
                                                 : sr        ? kFlightSr
                                                             : kFlightNoSr),
                                  "--domain",
                                  std::to_string(rejuv::test_support::kOwnDdsDomain),
                                  "--net-port",
                                  "0",
                                  "--summary-json",
                                  json.string()};
    if (!kind.empty()) args.insert(args.begin() + 2, std::initializer_list<std::string>{"--attack", kind});
    if (!sr) args.emplace_back("--no-sr");
    const auto r = rejuv::test_support::run_rejuv(dir_, args);
    Flight f;
    f.exit_code = r.exit_code;
    f.err = r.err;
    const auto status = google::protobuf::util::JsonStringToMessage(rejuv::test_support::slurp(json), &f.summary);
    EXPECT_TRUE(status.ok()) << kind << (sr ? " SR" : " no SR") << ": no summary; stderr:\n" << r.err;
    std::printf("[ %s, SR %s ] exit %d, max V %.4f, d_max %.1f cm, %llu attacked windows, %llu rollbacks, %.1f s\n",
                kind.c_str(), sr ? "on" : "off", r.exit_code, f.summary.max_v(), 100.0 * f.summary.d_max_m(),
                static_cast<unsigned long long>(f.summary.attacks()),
                static_cast<unsigned long long>(f.summary.rollbacks()), f.summary.mission_time_s());
    return f;
  }

  // The kind's two missions and what they must show.
  void harms_without_sr_contained_with_sr(const std::string& kind) {
    const Flight off = fly(kind, false);
    EXPECT_EQ(off.summary.attack_kind(), kind);
    EXPECT_EQ(off.exit_code, 1) << off.err;
    EXPECT_GE(off.summary.max_v(), 1.0) << "without SR the attack must leave the safety set";
    EXPECT_TRUE(off.summary.left_safety_set());
    EXPECT_GT(off.summary.d_max_m(), 0.5) << "the vehicle more than 50 cm off the square";

    const Flight on = fly(kind, true);
    EXPECT_EQ(on.summary.attack_kind(), kind);
    EXPECT_EQ(on.exit_code, 0) << on.err;
    EXPECT_LT(on.summary.max_v(), 1.0) << "with SR the vehicle stays inside the safety set";
    EXPECT_FALSE(on.summary.left_safety_set());
    // Every MC window is attacked (the plan's max_windows 0), and every one ends in a rollback. The summary's
    // `attacks` counts a library kind's windows by the plan (the run recorder: its effect on the controls has
    // no signature), as the model does: every MC window, the last one perhaps still open.
    EXPECT_GE(on.summary.rollbacks(), 3U) << "attacked MC windows, each rolled back";
    EXPECT_GE(on.summary.attacks(), on.summary.rollbacks()) << "every rolled-back MC window was attacked";
    EXPECT_LE(on.summary.attacks(), on.summary.rollbacks() + 1);
    // Counted by kind (the summary's attacks_by_kind): the plan's one attack, fired in the windows the
    // summary counts, denied nothing (it acts through the service's own data), its effect the run's max V.
    for (const Flight* f : {&off, &on}) {
      ASSERT_EQ(f->summary.attacks_by_kind_size(), 1) << f->summary.DebugString();
      const rejuv::proto::AttackKindSummary& row = f->summary.attacks_by_kind(0);
      EXPECT_EQ(row.kind(), kind);
      EXPECT_GT(row.windows_fired(), 0U);
      EXPECT_EQ(row.denied(), 0U);
      EXPECT_LE(row.max_v(), f->summary.max_v());
    }
    EXPECT_TRUE(off.summary.attacks_by_kind(0).left_safety_set()) << "the harm shows in the kind's spans";
    EXPECT_EQ(off.summary.attacks_by_kind(0).windows_fired(), 1U) << "without SR: one endless window";
    EXPECT_FALSE(on.summary.attacks_by_kind(0).left_safety_set());
    // The plan's windows by the kernel's steps, and the summary's by the controls the recorder sees: the
    // same windows, the last one perhaps counted by one of them only.
    EXPECT_LE(std::max(on.summary.attacks_by_kind(0).windows_fired(), on.summary.attacks()) -
                  std::min(on.summary.attacks_by_kind(0).windows_fired(), on.summary.attacks()),
              1U);
  }
};

// Attacks counted by kind: the square's worst-case control attack beside FORGED_SLOT in commander for two
// windows. Each kind fired; what the kernel denied is FORGED_SLOT's alone and is every capability denial of
// the run (the summary's per-reason `denials`); the vehicle stayed inside the safety set through both.
TEST_F(AttackLibrary, TwoKindsInOnePlan_CountedByKindDenialsMatchTheReasons) {
  std::string text = rejuv::test_support::slurp(kRepo / "launch/quad_square_paper.launch.pbtxt");
  const std::string policy = "policy: \"../policies/quad_sr.policy.pbtxt\"";
  const std::string control = "attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }";
  const std::size_t policy_at = text.find(policy);
  ASSERT_NE(policy_at, std::string::npos);
  text.replace(policy_at, policy.size(),
               "policy: \"" + (kRepo / "policies/quad_sr.policy.pbtxt").string() + "\"");
  const std::size_t control_at = text.find(control);
  ASSERT_NE(control_at, std::string::npos);
  text.insert(control_at + control.size(),
              "\n  attacks { kind: FORGED_SLOT service: \"commander\" max_windows: 2 }");
  const fs::path graph = dir_ / "two_kinds.launch.pbtxt";
  {
    std::ofstream out(graph);
    out << text;
  }
  const Flight f = fly("", true, graph, 12.0);
  EXPECT_EQ(f.exit_code, 0) << f.err;
  ASSERT_EQ(f.summary.attacks_by_kind_size(), 2) << f.summary.DebugString();
  const rejuv::proto::AttackKindSummary& control_row = f.summary.attacks_by_kind(0);
  const rejuv::proto::AttackKindSummary& forged = f.summary.attacks_by_kind(1);
  EXPECT_EQ(control_row.kind(), "WORST_CASE_CONTROL");
  EXPECT_EQ(control_row.service(), "lqr_control");
  EXPECT_GT(control_row.windows_fired(), 0U);
  EXPECT_EQ(control_row.denied(), 0U);
  EXPECT_FALSE(control_row.left_safety_set());
  EXPECT_EQ(forged.kind(), "FORGED_SLOT");
  EXPECT_EQ(forged.service(), "commander");
  ASSERT_GE(f.summary.rollbacks(), 2U) << "two MC windows flown after the first";
  EXPECT_EQ(forged.windows_fired(), 2U) << "max_windows";
  EXPECT_GT(forged.denied(), 0U);
  EXPECT_EQ(forged.contained(), 0U);
  // The per-reason count: every capability error (the keys that are not the kernel's other counters).
  std::uint64_t by_reason = 0;
  for (const auto& [reason, n] : f.summary.denials()) {
    const std::vector<std::string> other{"BadFrame",  "SandboxViolation", "FloodDropped",
                                         "WrongSize", "RingOverrun",      "TimerArmedTwice"};
    if (std::find(other.begin(), other.end(), reason) == other.end()) by_reason += n;
  }
  EXPECT_EQ(forged.denied() + control_row.denied(), by_reason) << f.summary.DebugString();
  EXPECT_FALSE(forged.left_safety_set());
}

TEST_F(AttackLibrary, EstimateShift_HarmsWithoutSrContainedWithSr) { harms_without_sr_contained_with_sr("ESTIMATE_SHIFT"); }
TEST_F(AttackLibrary, SensorBias_HarmsWithoutSrContainedWithSr) { harms_without_sr_contained_with_sr("SENSOR_BIAS"); }
TEST_F(AttackLibrary, SetpointShift_HarmsWithoutSrContainedWithSr) { harms_without_sr_contained_with_sr("SETPOINT_SHIFT"); }
TEST_F(AttackLibrary, GainOverwrite_HarmsWithoutSrContainedWithSr) { harms_without_sr_contained_with_sr("GAIN_OVERWRITE"); }
TEST_F(AttackLibrary, EstimateDrift_HarmsWithoutSrContainedWithSr) { harms_without_sr_contained_with_sr("ESTIMATE_DRIFT"); }

// --attack is case-insensitive and an unknown kind is refused before any work, naming the valid ones.
TEST_F(AttackLibrary, UnknownKind_Exit2ListingTheKinds) {
  const auto r = rejuv::test_support::run_rejuv(
      dir_, {"run", (kRepo / "launch/quad_square_paper.launch.pbtxt").string(), "--attack", "ESTIMATE_SHIFTY"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown attack kind 'ESTIMATE_SHIFTY'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("WORST_CASE_CONTROL, ESTIMATE_SHIFT, SENSOR_BIAS"), std::string::npos) << r.err;
}

}  // namespace
