// A full CPS SR mode cycle on the capability kernel compiled from the reference policy (docs/design.md §3: a mode
// transition is revoke + mint, applied atomically): MC → RB → SC → UPDATE → CP → MC on quad_sr.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>

#include "rejuv/cap/cap_system.hpp"
#include "rejuv/policy/policy.hpp"

namespace {

rejuv::cap::CapSystem make_quad_sr_caps() {
  const auto policy = rejuv::policy::load_policy(REJUV_SOURCE_DIR "/policies/quad_sr.policy.pbtxt");
  if (!policy) {
    std::fprintf(stderr, "%s\n", policy.error().to_string().c_str());
    std::exit(2);
  }
  auto caps = rejuv::cap::CapSystem::create(rejuv::policy::compile(*policy));
  if (!caps) {
    std::fprintf(stderr, "cannot build the capability kernel from quad_sr\n");
    std::exit(2);
  }
  return std::move(*caps);
}

// One transition, both directions measured together: MC ↔ RB is the transition on the rollback path.
void BM_QuadSr_ModeTransition_McRb(benchmark::State& state) {
  auto caps = make_quad_sr_caps();
  std::size_t changed = 0;
  for (auto _ : state) {
    auto to_rb = caps.apply_mode(rejuv::SrMode::RB);
    auto to_mc = caps.apply_mode(rejuv::SrMode::MC);
    if (!to_rb || !to_mc) {
      state.SkipWithError("apply_mode failed");
      return;
    }
    changed = to_rb->slots_changed + to_mc->slots_changed;
    benchmark::DoNotOptimize(changed);
  }
  state.counters["slots_changed_per_pair"] = static_cast<double>(changed);
  state.counters["transitions_per_iter"] = 2;
}
BENCHMARK(BM_QuadSr_ModeTransition_McRb)->Unit(benchmark::kMicrosecond);

// The whole Fig. 1 cycle: five transitions.
void BM_QuadSr_ModeCycle(benchmark::State& state) {
  auto caps = make_quad_sr_caps();
  constexpr rejuv::SrMode kCycle[] = {rejuv::SrMode::MC, rejuv::SrMode::RB, rejuv::SrMode::SC,
                                      rejuv::SrMode::Update, rejuv::SrMode::CP};
  for (auto _ : state) {
    for (const rejuv::SrMode m : kCycle) {
      if (!caps.apply_mode(m)) {
        state.SkipWithError("apply_mode failed");
        return;
      }
    }
  }
  state.counters["transitions_per_iter"] = 5;
}
BENCHMARK(BM_QuadSr_ModeCycle)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
