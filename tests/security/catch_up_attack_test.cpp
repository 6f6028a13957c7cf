// A compromised `sensors` against the estimate catch-up (idl/launch.proto SLOW_REPLAY, LYING_REPLAY;
// services/sensors/src/replay_attack.cpp; docs/control.md §6.3 "What the catch-up trusts"): it acts only on the
// samples the kernel replays after a rollback; live data stays honest. launch/quad_square (the catch-up on, the
// worst-case control attack in every MC window) flown through the real kernel, the real flight services and the
// plant — in REAL TIME and in LOCKSTEP.
//
// Judged by effect: the vehicle stayed in the safety set (max V < 1); every replay that could not be used ended
// in a re-arm, counted (a slow chain: cut_short ≥ 1; a lying chain: discarded ≥ 1); no rollback fell back to an
// older generation, none ended in a cold restart; sensors was never killed for its replay work (no violation).
// No timing is asserted.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "graph_fixture.hpp"
#include "mission_support.hpp"
#include "run_recorder.hpp"
#include "run_summary.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using kernel::Kernel;
using kernel::StopReason;

constexpr std::chrono::seconds kFlight{12};

struct Case {
  const char* kind;
  bool realtime;
  double magnitude;  // SLOW_REPLAY: ms per replayed tick; LYING_REPLAY: the accelerometer's factor
};

struct Flight {
  proto::RunSummary summary;
  kernel::RunOutcome outcome;
  kernel::SrStats sr;
  kernel::CatchUpStats catch_up;
  kernel::ServiceStats sensors;
};

void fly(const Case& c, Flight& f) {
  std::optional<launch::LoadedLaunch> graph;
  ASSERT_NO_FATAL_FAILURE(mission::load_square(c.realtime,
                                               "attacks { kind: " + std::string(c.kind) + " service: \"sensors\" magnitude: " +
                                                   std::to_string(c.magnitude) + " }",
                                               graph));
  auto reference = cli::run_reference(*graph, std::nullopt);
  ASSERT_TRUE(reference.has_value()) << reference.error();
  mission::RunLog log;
  ASSERT_NE(log.get(), nullptr);
  kernel::KernelOptions options = mission::mission_options(log.get());
  options.duration = reference->alignment + Nanos{kFlight};
  mission::SessionGuard guard;
  cli::RunRecorder recorder(std::move(*reference), nullptr, cli::RunRecorder::Progress::Off);
  auto k = Kernel::create(std::move(*graph), options, &recorder);
  ASSERT_TRUE(k.has_value()) << k.error().to_string();
  recorder.on_vehicle_lost([kernel = k->get()] { (*kernel).request_stop(); });
  auto outcome = (*k)->run();
  ASSERT_TRUE(outcome.has_value()) << outcome.error().to_string() << "\n" << log.text();
  f.outcome = *outcome;
  cli::fill_summary(f.summary, **k, recorder, *outcome, cli::facts_of(**k, options));
  f.sr = (*k)->sr_stats();
  f.catch_up = (*k)->catch_up_stats();
  const auto id = (*k)->find_service("sensors");
  ASSERT_TRUE(id.has_value());
  f.sensors = (*k)->stats(*id);
  k->reset();
  std::printf("[ %s %s m=%g ] max V %.3f, %llu rollbacks, %llu fallbacks, %llu cold restarts; catch-up: %llu replays, "
              "%llu cut short, %llu discarded; sensors: %llu violations\n",
              c.kind, c.realtime ? "real time" : "lockstep", c.magnitude, f.summary.max_v(),
              static_cast<unsigned long long>(f.sr.rollbacks), static_cast<unsigned long long>(f.sr.fallbacks),
              static_cast<unsigned long long>(f.sr.cold_restarts), static_cast<unsigned long long>(f.catch_up.replays),
              static_cast<unsigned long long>(f.catch_up.cut_short),
              static_cast<unsigned long long>(f.catch_up.discarded),
              static_cast<unsigned long long>(f.sensors.sandbox_violations));
}

void expect_held(const Flight& f) {
  EXPECT_EQ(f.outcome.reason, StopReason::Duration) << f.outcome.detail;
  EXPECT_LT(f.summary.max_v(), 1.0) << "the vehicle left the safety set";
  EXPECT_FALSE(f.summary.left_safety_set());
  EXPECT_GE(f.sr.rollbacks, 2U) << "too few rollbacks for the attack to matter";
  EXPECT_EQ(f.sr.fallbacks, 0U) << "a rollback fell back to an older generation";
  EXPECT_EQ(f.sr.cold_restarts, 0U);
  EXPECT_EQ(f.sensors.sandbox_violations, 0U) << "sensors was killed for its replay work";
}

class CatchUpAttack : public ::testing::TestWithParam<Case> {};

// A chain too slow to catch up: every replay ends at the kernel's bound in a re-arm, never at RLIMIT_RTTIME.
TEST_P(CatchUpAttack, SlowOrLyingChain_EndsInARearm_VehicleStaysSafe) {
  const Case& c = GetParam();
  Flight f;
  fly(c, f);
  if (HasFatalFailure()) return;
  expect_held(f);
  if (std::string_view(c.kind) == "SLOW_REPLAY") {
    EXPECT_GE(f.catch_up.cut_short, 1U) << "no replay was cut short";
  } else if (c.realtime) {
    // In real time a replay may also end at the kernel's bound before it is judged: the restored filter is
    // re-armed either way, and the lie does not stick (max V above).
    EXPECT_GE(f.catch_up.discarded + f.catch_up.cut_short, 1U) << "no lying replay ended in a re-arm";
  } else {
    EXPECT_GE(f.catch_up.discarded, 1U) << "no lying replay was discarded";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, CatchUpAttack,
    ::testing::Values(Case{"SLOW_REPLAY", true, 3.0}, Case{"SLOW_REPLAY", false, 200.0},
                      Case{"LYING_REPLAY", true, 3.0}, Case{"LYING_REPLAY", false, 3.0}),
    [](const ::testing::TestParamInfo<Case>& p) {
      return std::string(p.param.kind == std::string_view("SLOW_REPLAY") ? "SlowReplay" : "LyingReplay") +
             (p.param.realtime ? "_RealTime" : "_Lockstep");
    });

}  // namespace
}  // namespace rejuv::testing
