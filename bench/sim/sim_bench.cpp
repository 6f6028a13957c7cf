// How fast the model-level SR simulation runs: the square mission of §VI-C (SR on, worst-case attack in every MC
// window) end to end, as a realtime factor = simulated time / elapsed time, on the wall clock and on this
// process's CPU clock (the second does not depend on what else the machine is doing). Side by side: the same
// mission without SR, and the one-time control design each run starts with.
#include <benchmark/benchmark.h>

#include <ctime>
#include <filesystem>

#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace {

using rejuv::flight::AttackSwitch;
using rejuv::flight::SimConfig;
using rejuv::flight::SrSwitch;

SimConfig square(SrSwitch sr, AttackSwitch attack) {
  const auto path = std::filesystem::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt";
  auto loaded = rejuv::launch::load_launch(path);
  if (!loaded) return SimConfig::defaults();
  auto config = rejuv::flight::config_from_launch(*loaded, {.sr = sr, .attack = attack, .seed = std::nullopt});
  return config ? *config : SimConfig::defaults();
}

double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

void run_mission(benchmark::State& state, SrSwitch sr, AttackSwitch attack) {
  const SimConfig config = square(sr, attack);
  double sim_s = 0, wall_s = 0, cpu_s = 0, max_V = 0, attacks = 0;
  for (auto _ : state) {
    const double cpu0 = cpu_seconds();
    const auto summary = rejuv::flight::run_simulation(config);
    cpu_s += cpu_seconds() - cpu0;
    if (!summary) {
      state.SkipWithError(summary.error().to_string().c_str());
      return;
    }
    // The alignment before t = 0 is simulated too: count it.
    sim_s += summary->sim_time_s() + config.alignment.count();
    wall_s += summary->wall_time_s();
    max_V = summary->max_v();
    attacks = static_cast<double>(summary->attacks());
  }
  state.counters["realtime_factor"] = sim_s / wall_s;
  state.counters["realtime_factor_cpu"] = sim_s / cpu_s;
  state.counters["sim_s"] = sim_s / static_cast<double>(state.iterations());
  state.counters["max_V"] = max_V;
  state.counters["attacks"] = attacks;
}

void BM_SquareMission_SrAttack(benchmark::State& state) { run_mission(state, SrSwitch::On, AttackSwitch::On); }
void BM_SquareMission_NoSrNoAttack(benchmark::State& state) {
  run_mission(state, SrSwitch::Off, AttackSwitch::Off);
}

void BM_ControlDesign(benchmark::State& state) {
  const SimConfig config = square(SrSwitch::On, AttackSwitch::On);
  for (auto _ : state) {
    auto design = rejuv::flight::design_control(config.control);
    benchmark::DoNotOptimize(design);
  }
}

}  // namespace

BENCHMARK(BM_SquareMission_SrAttack)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_SquareMission_NoSrNoAttack)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_ControlDesign)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
