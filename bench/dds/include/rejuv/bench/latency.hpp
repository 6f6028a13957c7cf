// Latency measurement shared by the benchmarks that compare message paths side by side (docs/design.md §11): a
// timed round-trip loop, one-way latency as RTT/2, percentiles, and Google Benchmark counters in µs. The raw
// DDS baseline (dds_ping_pong.hpp) and the kernel's publish→deliver path report through the same functions,
// so their numbers mean the same thing.
#pragma once

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::bench {

// Runs `count` round trips, timing each with steady_clock: round_trip(seq) sends message `seq` and returns
// once its reply is back, or an error that ends the measurement. seq counts from `first_seq`.
template <class RoundTrip>
[[nodiscard]] Result<std::vector<Nanos>, std::string> measure_round_trips(std::size_t count,
                                                                          RoundTrip&& round_trip,
                                                                          std::uint64_t first_seq = 1) {
  std::vector<Nanos> rtts;
  rtts.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    if (auto ok = round_trip(first_seq + i); !ok) {
      return fail(std::string("round trip ") + std::to_string(i) + ": " + ok.error());
    }
    const auto t1 = std::chrono::steady_clock::now();
    rtts.push_back(std::chrono::duration_cast<Nanos>(t1 - t0));
  }
  return rtts;
}

// One-way latency of each round trip, estimated as RTT/2 (both directions take the same path).
[[nodiscard]] inline std::vector<Nanos> one_way_from_round_trips(std::span<const Nanos> rtts) {
  std::vector<Nanos> out;
  out.reserve(rtts.size());
  for (const Nanos rtt : rtts) out.push_back(rtt / 2);
  return out;
}

struct LatencySummary {
  std::size_t count = 0;
  Nanos min{0};
  Nanos p50{0};
  Nanos p90{0};
  Nanos p99{0};
  Nanos max{0};
  Nanos mean{0};
};

// Nearest-rank percentiles of the samples (empty samples give an all-zero summary).
[[nodiscard]] inline LatencySummary summarize(std::vector<Nanos> samples) {
  LatencySummary s;
  s.count = samples.size();
  if (samples.empty()) return s;
  std::sort(samples.begin(), samples.end());
  const auto rank = [&](double p) {
    const auto r = static_cast<std::size_t>(p / 100.0 * static_cast<double>(samples.size()) + 0.5);
    return samples[std::clamp<std::size_t>(r, 1, samples.size()) - 1];
  };
  s.min = samples.front();
  s.max = samples.back();
  s.p50 = rank(50);
  s.p90 = rank(90);
  s.p99 = rank(99);
  s.mean =
      std::accumulate(samples.begin(), samples.end(), Nanos{0}) / static_cast<std::int64_t>(samples.size());
  return s;
}

// Counters "<prefix>p50_us", "<prefix>p99_us", ... in microseconds, plus "<prefix>samples".
inline void set_latency_counters(benchmark::State& state, const LatencySummary& s,
                                 std::string_view prefix = "one_way_") {
  const auto us = [](Nanos t) { return std::chrono::duration<double, std::micro>(t).count(); };
  const std::string p(prefix);
  state.counters[p + "p50_us"] = us(s.p50);
  state.counters[p + "p90_us"] = us(s.p90);
  state.counters[p + "p99_us"] = us(s.p99);
  state.counters[p + "min_us"] = us(s.min);
  state.counters[p + "max_us"] = us(s.max);
  state.counters[p + "mean_us"] = us(s.mean);
  state.counters[p + "samples"] = static_cast<double>(s.count);
}

}  // namespace rejuv::bench
