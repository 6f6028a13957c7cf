// Raw Cyclone DDS latency between two processes (docs/design.md §11): the baseline for the kernel's publish→deliver
// path. Ping-pong with rejuv_dds_echo over loopback; one-way latency = RTT/2, reported as p50/p99 counters
// in µs. Two receive paths side by side (dds_ping_pong.hpp): Cyclone alone (waitset) and the kernel's DDS
// bridge (listener → eventfd → poll → take); payloads are real topic types of 48, 112 and 216 bytes.
#include <benchmark/benchmark.h>

#include <stdlib.h>
#include <unistd.h>

#include <string>

#include "rejuv/bench/dds_ping_pong.hpp"
#include "rejuv/bench/latency.hpp"

namespace {

using namespace rejuv;
using bench::DdsPath;

constexpr std::size_t kRoundTrips = 5000;

std::string cyclone_uri() {
  // A URI given by the caller wins (another config, another host); otherwise the repo's loopback config.
  const char* given = ::getenv("CYCLONEDDS_URI");
  return given != nullptr ? std::string(given) : "file://" REJUV_SOURCE_DIR "/config/cyclonedds.xml";
}

void BM_DdsOneWayLatency(benchmark::State& state, DdsPath path, const std::string& type_name) {
  const std::string uri = cyclone_uri();
  ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  auto pp = bench::DdsPingPong::start(bench::PingPongOptions{
      .domain = dds::DomainId{1 + static_cast<std::uint32_t>(::getpid()) % dds::kMaxDomainId},
      .type_name = type_name,
      .path = path,
      .echo_executable = REJUV_DDS_ECHO,
      .cyclone_uri = uri,
      .warmup_round_trips = 200,
      .reply_timeout = std::chrono::seconds{5},
      .connect_timeout = std::chrono::seconds{20}});
  if (!pp) {
    state.SkipWithError(pp.error().c_str());
    return;
  }
  std::vector<Nanos> rtts;
  for (auto _ : state) {
    auto run = pp->run(kRoundTrips);
    if (!run) {
      state.SkipWithError(run.error().c_str());
      return;
    }
    rtts.insert(rtts.end(), run->begin(), run->end());
  }
  bench::set_latency_counters(state, bench::summarize(bench::one_way_from_round_trips(rtts)), "one_way_");
  state.counters["rtt_p50_us"] =
      std::chrono::duration<double, std::micro>(bench::summarize(rtts).p50).count();
  state.counters["payload_bytes"] = static_cast<double>(pp->payload_size());
  state.SetLabel(std::string(bench::to_string(path)) + " " + type_name);
}

// One iteration = kRoundTrips round trips: the distribution is the result, not the mean time per iteration.
#define REJUV_DDS_LATENCY(path, short_name, type_name)                                  \
  BENCHMARK_CAPTURE(BM_DdsOneWayLatency, path##_##short_name, DdsPath::path, type_name) \
      ->Iterations(1)                                                                   \
      ->Unit(benchmark::kMillisecond)

REJUV_DDS_LATENCY(RawWaitset, ActuatorOutputs_48B, "rejuv::msg::ActuatorOutputs");
REJUV_DDS_LATENCY(RawWaitset, GroundTruth_112B, "rejuv::msg::GroundTruth");
REJUV_DDS_LATENCY(RawWaitset, VehicleStateEstimate_216B, "rejuv::msg::VehicleStateEstimate");
REJUV_DDS_LATENCY(BridgeEventFd, ActuatorOutputs_48B, "rejuv::msg::ActuatorOutputs");
REJUV_DDS_LATENCY(BridgeEventFd, GroundTruth_112B, "rejuv::msg::GroundTruth");
REJUV_DDS_LATENCY(BridgeEventFd, VehicleStateEstimate_216B, "rejuv::msg::VehicleStateEstimate");

}  // namespace

BENCHMARK_MAIN();
