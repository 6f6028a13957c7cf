// Cost of loading and auditing the reference policy (docs/design.md §4): `rejuv run` audits before it starts a
// graph, so this is start-up latency. Side by side: parse only, parse + validate, audit alone, audit with
// the launch graph, and compilation to the kernel's ModeTable.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "policy.pb.h"
#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/policy.hpp"

namespace {

const std::filesystem::path kPolicy =
    std::filesystem::path(REJUV_SOURCE_DIR) / "policies" / "quad_sr.policy.pbtxt";
const std::filesystem::path kLaunch =
    std::filesystem::path(REJUV_SOURCE_DIR) / "launch" / "quad_square_paper.launch.pbtxt";

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Baseline: protobuf text-format parsing alone (no validation, no model).
void BM_ParseTextprotoOnly(benchmark::State& state) {
  const std::string text = read_all(kPolicy);
  for (auto _ : state) {
    rejuv::proto::Policy pb;
    auto locs = rejuv::parse_textproto(text, "quad_sr", pb);
    benchmark::DoNotOptimize(locs);
  }
}
BENCHMARK(BM_ParseTextprotoOnly)->Unit(benchmark::kMicrosecond);

void BM_ParsePolicy(benchmark::State& state) {
  const std::string text = read_all(kPolicy);
  for (auto _ : state) {
    auto p = rejuv::policy::parse_policy(text, "quad_sr");
    benchmark::DoNotOptimize(p);
  }
}
BENCHMARK(BM_ParsePolicy)->Unit(benchmark::kMicrosecond);

void BM_Audit(benchmark::State& state) {
  const auto p = rejuv::policy::load_policy(kPolicy);
  if (!p) {
    state.SkipWithError(p.error().to_string().c_str());
    return;
  }
  for (auto _ : state) {
    auto f = rejuv::policy::audit(*p);
    benchmark::DoNotOptimize(f);
  }
}
BENCHMARK(BM_Audit)->Unit(benchmark::kMicrosecond);

void BM_AuditWithLaunch(benchmark::State& state) {
  const auto p = rejuv::policy::load_policy(kPolicy);
  const auto g = rejuv::launch::load_launch(kLaunch);
  if (!p || !g) {
    state.SkipWithError("cannot load the shipped policy or launch graph");
    return;
  }
  for (auto _ : state) {
    auto f = rejuv::policy::audit(*p, *g);
    benchmark::DoNotOptimize(f);
  }
}
BENCHMARK(BM_AuditWithLaunch)->Unit(benchmark::kMicrosecond);

// What `rejuv audit POLICY` does besides printing: read the file, parse, validate, audit.
void BM_LoadAndAudit(benchmark::State& state) {
  for (auto _ : state) {
    const auto p = rejuv::policy::load_policy(kPolicy);
    if (!p) {
      state.SkipWithError(p.error().to_string().c_str());
      return;
    }
    auto f = rejuv::policy::audit(*p);
    benchmark::DoNotOptimize(f);
  }
}
BENCHMARK(BM_LoadAndAudit)->Unit(benchmark::kMicrosecond);

void BM_LoadLaunch(benchmark::State& state) {
  for (auto _ : state) {
    auto g = rejuv::launch::load_launch(kLaunch);
    benchmark::DoNotOptimize(g);
  }
}
BENCHMARK(BM_LoadLaunch)->Unit(benchmark::kMicrosecond);

void BM_Compile(benchmark::State& state) {
  const auto p = rejuv::policy::load_policy(kPolicy);
  if (!p) {
    state.SkipWithError(p.error().to_string().c_str());
    return;
  }
  for (auto _ : state) {
    auto t = rejuv::policy::compile(*p);
    benchmark::DoNotOptimize(t);
  }
}
BENCHMARK(BM_Compile)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
