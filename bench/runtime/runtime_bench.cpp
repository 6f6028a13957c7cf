// Whole-system benchmarks of the runtime (docs/design.md §11), each beside its baseline in the same run.
//
// 1. Publish→deliver latency through the kernel: two services (rejuv_bench_pingpong: ping, pong) exchange
//    one message at a time through the kernel in realtime mode — Unix SOCK_SEQPACKET channel in, capability
//    check, broker ring, channel out, both ways. Beside it, a raw Cyclone DDS writer→reader ping-pong between
//    two processes on the same payload (bench/dds, RawWaitset). One-way latency = RTT/2 for both; the
//    counters kernel_*/dds_* and ratio_p50 = kernel/dds (target ≤ 1.0).
// 2. Lockstep speed: the square mission and a 20 s hover on the real services with the plant as time master,
//    each after the plant's 20 s pre-flight alignment (realtime_factor = simulated / wall time, alignment
//    included: the runtime steps through it like through the flight; target ≥ 20×).
#include <benchmark/benchmark.h>

#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rejuv/bench/dds_ping_pong.hpp"
#include "rejuv/bench/latency.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"

namespace {

using namespace rejuv;
namespace fs = std::filesystem;

constexpr std::size_t kRoundTrips = 5000;
constexpr std::size_t kWarmup = 200;

std::string cyclone_uri() {
  const char* given = ::getenv("CYCLONEDDS_URI");
  return given != nullptr ? std::string(given) : "file://" REJUV_SOURCE_DIR "/config/cyclonedds.xml";
}

std::uint32_t domain(std::uint32_t offset) {
  return 1 + (static_cast<std::uint32_t>(sys::current_pid()) + offset) % dds::kMaxDomainId;
}

double us(Nanos t) { return std::chrono::duration<double, std::micro>(t).count(); }

struct Row {
  std::string what;
  double kernel_p50 = 0, kernel_p99 = 0, dds_p50 = 0, dds_p99 = 0;
};
std::vector<Row>& rows() {
  static std::vector<Row> r;
  return r;
}
struct MissionRow {
  std::string what;
  double sim_s = 0, wall_s = 0, factor = 0;
  std::uint64_t steps = 0;
  std::string outcome;
};
std::vector<MissionRow>& mission_rows() {
  static std::vector<MissionRow> r;
  return r;
}

// Collects the ping service's round-trip times from topic "results" and ends the run after the last.
class Results final : public kernel::Observer {
 public:
  void on_publication(const kernel::Publication& p) override {
    if (p.name != "results") return;
    rejuv_msg_MissionWaypoints m{};
    std::memcpy(&m, p.payload.data(), sizeof(m));
    if (m.acceptance_radius_m < 0) {
      if (kernel != nullptr) kernel->request_stop();
      return;
    }
    for (std::uint32_t i = 0; i < m.count && i < 16; ++i) {
      rtts.push_back(Nanos{static_cast<std::int64_t>(m.waypoints[i].p_N_m[0])});
    }
  }
  kernel::Kernel* kernel = nullptr;
  std::vector<Nanos> rtts;
};

// The two-service graph, written for one payload type.
Result<launch::LoadedLaunch, std::string> pingpong_graph(const fs::path& dir, const std::string& type) {
  fs::create_directories(dir);
  std::ofstream(dir / "bench.policy.pbtxt")
      << "name: \"bench_pingpong\"\n"
         "services { name: \"ping\" }\nservices { name: \"pong\" }\n"
         "objects { name: \"ping\" kind: TOPIC type: \"" << type << "\" queue_depth: 8 }\n"
         "objects { name: \"pong\" kind: TOPIC type: \"" << type << "\" queue_depth: 8 }\n"
         "objects { name: \"results\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" kernel: KERNEL_SUBSCRIBES "
         "queue_depth: 64 }\n"
         "grants { service: \"ping\" object: \"ping\" rights: \"W\" modes: [MC] }\n"
         "grants { service: \"ping\" object: \"pong\" rights: \"R\" modes: [MC] }\n"
         "grants { service: \"ping\" object: \"results\" rights: \"W\" modes: [MC] }\n"
         "grants { service: \"pong\" object: \"ping\" rights: \"R\" modes: [MC] }\n"
         "grants { service: \"pong\" object: \"pong\" rights: \"W\" modes: [MC] }\n";
  const auto service = [&](const std::string& name, const std::string& uses) {
    return "services { name: \"" + name + "\" executable: \"rejuv_bench_pingpong\" params { name: \"role\" text: \"" +
           name + "\" } params { name: \"type\" text: \"" + type + "\" } params { name: \"count\" number: " +
           std::to_string(kRoundTrips) + " } params { name: \"warmup\" number: " + std::to_string(kWarmup) + " } " +
           uses + " }\n";
  };
  std::ofstream(dir / "bench.launch.pbtxt")
      << "name: \"bench_pingpong\"\npolicy: \"bench.policy.pbtxt\"\nclock: REALTIME\n"
      // A ping-pong publishes as fast as the kernel routes: above the default publication budget, which is
      // sized for a flight (docs/sandbox.md "Floods cost only the flooder").
      << "sandbox_limits { max_publications_per_s: 1000000 }\n"
      << service("ping", "uses { object: \"ping\" rights: \"W\" } uses { object: \"pong\" rights: \"R\" } "
                         "uses { object: \"results\" rights: \"W\" }")
      << service("pong", "uses { object: \"ping\" rights: \"R\" } uses { object: \"pong\" rights: \"W\" }")
      << "mission { waypoints { down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 600 }\n";
  auto loaded = launch::load_launch(dir / "bench.launch.pbtxt");
  if (!loaded) return fail(loaded.error().to_string());
  return std::move(*loaded);
}

Result<std::vector<Nanos>, std::string> kernel_round_trips(const std::string& type) {
  const fs::path dir = fs::temp_directory_path() / ("rejuv_runtime_bench_" + std::to_string(sys::current_pid()));
  auto graph = pingpong_graph(dir, type);
  if (!graph) return fail(graph.error());
  kernel::KernelOptions options;
  options.service_dir = REJUV_SERVICE_DIR;
  options.repo_root = REJUV_SOURCE_DIR;
  options.duration = std::chrono::seconds{120};  // a bound, not a measurement
  Results results;
  auto k = kernel::Kernel::create(std::move(*graph), options, &results);
  fs::remove_all(dir);  // the kernel has read the policy
  if (!k) return fail(k.error().to_string());
  results.kernel = k->get();
  auto outcome = (*k)->run();
  if (!outcome) return fail(outcome.error().to_string());
  if (results.rtts.size() != kRoundTrips) {
    return fail("got " + std::to_string(results.rtts.size()) + " round trips (" +
                std::string(kernel::to_string(outcome->reason)) + ": " + outcome->detail + ")");
  }
  return results.rtts;
}

void BM_PublishDeliverLatency(benchmark::State& state, const std::string& type) {
  ::setenv("CYCLONEDDS_URI", cyclone_uri().c_str(), 1);
  std::vector<Nanos> kernel_rtts;
  std::vector<Nanos> dds_rtts;
  for (auto _ : state) {
    auto through_kernel = kernel_round_trips(type);
    if (!through_kernel) {
      state.SkipWithError(("kernel path: " + through_kernel.error()).c_str());
      return;
    }
    kernel_rtts = std::move(*through_kernel);
    auto pp = bench::DdsPingPong::start(bench::PingPongOptions{.domain = dds::DomainId{domain(7)},
                                                               .type_name = type,
                                                               .path = bench::DdsPath::RawWaitset,
                                                               .echo_executable = REJUV_DDS_ECHO,
                                                               .cyclone_uri = cyclone_uri(),
                                                               .warmup_round_trips = kWarmup,
                                                               .reply_timeout = std::chrono::seconds{5},
                                                               .connect_timeout = std::chrono::seconds{20}});
    if (!pp) {
      state.SkipWithError(("DDS baseline: " + pp.error()).c_str());
      return;
    }
    auto run = pp->run(kRoundTrips);
    if (!run) {
      state.SkipWithError(("DDS baseline: " + run.error()).c_str());
      return;
    }
    dds_rtts = std::move(*run);
  }
  const auto k = bench::summarize(bench::one_way_from_round_trips(kernel_rtts));
  const auto d = bench::summarize(bench::one_way_from_round_trips(dds_rtts));
  bench::set_latency_counters(state, k, "kernel_");
  bench::set_latency_counters(state, d, "dds_");
  state.counters["ratio_p50"] = us(k.p50) / us(d.p50);
  state.counters["ratio_p99"] = us(k.p99) / us(d.p99);
  state.SetLabel(type);
  rows().push_back(Row{type, us(k.p50), us(k.p99), us(d.p50), us(d.p99)});
}

void BM_LockstepMission(benchmark::State& state, const std::string& graph_file, double duration_s) {
  ::setenv("CYCLONEDDS_URI", cyclone_uri().c_str(), 1);
  const fs::path graph_path = fs::path(REJUV_SOURCE_DIR) / graph_file;
  auto graph = launch::load_launch(graph_path);
  if (!graph) {
    state.SkipWithError(graph.error().to_string().c_str());
    return;
  }
  kernel::KernelOptions options;
  options.service_dir = REJUV_SERVICE_DIR;
  options.repo_root = REJUV_SOURCE_DIR;
  options.no_sr = true;
  options.no_attack = true;
  options.dds_domain = domain(11);
  // The graph's alignment (launch lockstep.alignment_s, 20 s as `rejuv sim`), which the kernel gives the plant.
  const double kAlignment_s = launch::alignment(graph->graph.lockstep()).count();
  if (duration_s > 0) {
    options.duration = to_nanos(Seconds{kAlignment_s + duration_s});
    options.stop_on_mission_done = false;
  }
  // Services not built yet are left out (the rejuvenation service is skipped without SR anyway).
  for (const proto::ServiceSpec& s : graph->graph.services()) {
    if (!fs::exists(fs::path(REJUV_SERVICE_DIR) / s.executable())) options.skip_services.push_back(s.name());
  }
  kernel::RunOutcome outcome;
  for (auto _ : state) {
    auto fresh = launch::load_launch(graph_path);
    if (!fresh) return;
    auto k = kernel::Kernel::create(std::move(*fresh), options);
    if (!k) {
      state.SkipWithError(k.error().to_string().c_str());
      return;
    }
    auto run = (*k)->run();
    if (!run) {
      state.SkipWithError(run.error().to_string().c_str());
      return;
    }
    outcome = *run;
  }
  const double sim_s = to_seconds(outcome.sim_time).count();
  const double wall_s = to_seconds(outcome.wall_time).count();
  state.counters["realtime_factor"] = wall_s > 0 ? sim_s / wall_s : 0;
  state.counters["sim_s"] = sim_s;
  state.counters["wall_s"] = wall_s;
  state.counters["steps"] = static_cast<double>(outcome.steps);
  state.counters["steps_per_s"] = wall_s > 0 ? static_cast<double>(outcome.steps) / wall_s : 0;
  state.SetLabel(graph_file + ": " + std::string(kernel::to_string(outcome.reason)));
  mission_rows().push_back(MissionRow{graph_file, sim_s, wall_s, wall_s > 0 ? sim_s / wall_s : 0, outcome.steps,
                                      std::string(kernel::to_string(outcome.reason))});
}

BENCHMARK_CAPTURE(BM_PublishDeliverLatency, ActuatorOutputs_48B, std::string("rejuv::msg::ActuatorOutputs"))
    ->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PublishDeliverLatency, GroundTruth_112B, std::string("rejuv::msg::GroundTruth"))
    ->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PublishDeliverLatency, VehicleStateEstimate_216B, std::string("rejuv::msg::VehicleStateEstimate"))
    ->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LockstepMission, hover_20s, std::string("launch/hover.launch.pbtxt"), 20.0)
    ->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LockstepMission, quad_square, std::string("launch/quad_square_paper.launch.pbtxt"), 0.0)
    ->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!rows().empty()) {
    std::printf("\npublish->deliver one-way latency (RTT/2, %zu round trips), microseconds\n", kRoundTrips);
    std::printf("%-34s %10s %10s %10s %10s %10s\n", "payload", "kernel p50", "kernel p99", "DDS p50", "DDS p99",
                "p50 ratio");
    for (const Row& r : rows()) {
      std::printf("%-34s %10.1f %10.1f %10.1f %10.1f %10.2f\n", r.what.c_str(), r.kernel_p50, r.kernel_p99,
                  r.dds_p50, r.dds_p99, r.kernel_p50 / r.dds_p50);
    }
  }
  if (!mission_rows().empty()) {
    std::printf("\nlockstep speed (no SR, no attack)\n%-34s %8s %8s %8s %8s  %s\n", "graph", "sim s", "wall s", "factor",
                "steps", "ended by");
    for (const MissionRow& r : mission_rows()) {
      std::printf("%-34s %8.1f %8.2f %7.1fx %8llu  %s\n", r.what.c_str(), r.sim_s, r.wall_s, r.factor,
                  static_cast<unsigned long long>(r.steps), r.outcome.c_str());
    }
  }
  return 0;
}
