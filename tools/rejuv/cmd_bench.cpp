// `rejuv bench images [GRAPH]`: checkpoint and rollback of a whole service graph — every rejuvenated
// service plus the queue state (docs/design.md §7) — side by side in one run with the restart-based baseline: a cold
// restart of the same services from their binaries (spawn, exec, boot protocol, Ready). Prints p50 and max
// of each and the ratios; the paper's PX4 kernel module took ≈20 ms to checkpoint and ≈15 ms to roll back.
//
// The kernel runs in manual lockstep without the plant (nothing moves; the services, their channels, rings
// and timers are the real ones) and is stepped 1 ms between operations, so checkpoint_p's own SR cycle
// (T_est ≥ 1 s) never starts during the measurement.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "args.hpp"
#include "common_options.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "run_child.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"

namespace rejuv::cli {
namespace {

// p50 and max, the way the run summary reports them (report.hpp).
template <class Samples>
proto::Percentiles summarize(const Samples& v) {
  proto::Percentiles p;
  fill_percentiles(p, v);
  return p;
}

struct ImageBench {
  std::uint64_t cycles = 200;
  std::uint64_t restarts = 20;
  std::uint64_t between = 1;  // simulated ms
};

double ms_since(Nanos start) { return static_cast<double>((sys::monotonic_now() - start).count()) / 1e6; }

// The table of `rejuv bench images`: checkpoint, rollback and cold restart beside the paper's, the phases and
// the ratios.
void print_images(const kernel::SrStats& sr, const std::string& name, std::size_t rejuvenated,
                  const std::vector<double>& cold) {
  const proto::Percentiles cp = summarize(sr.checkpoint_ms);
  const proto::Percentiles rb = summarize(sr.rollback_ms);
  const proto::Percentiles cr = summarize(cold);
  std::printf("images: %s, %zu rejuvenated services + queue state, %zu checkpoints, %zu rollbacks, %zu cold restarts\n",
              name.c_str(), rejuvenated, static_cast<std::size_t>(sr.checkpoint_ms.count()),
              static_cast<std::size_t>(sr.rollback_ms.count()), cold.size());
  std::printf("%-14s %10s %10s   %s\n", "", "p50 [ms]", "max [ms]", "paper (PX4 kernel module)");
  std::printf("%-14s %10.3f %10.3f   ≈20 ms\n", "checkpoint", cp.p50(), cp.max());
  std::printf("%-14s %10.3f %10.3f   ≈15 ms\n", "rollback", rb.p50(), rb.max());
  std::printf("%-14s %10.3f %10.3f   (restart-based baseline)\n", "cold restart", cr.p50(), cr.max());
  proto::ImagePhases ph;
  fill_image_phases(ph, sr);
  const auto phase = [](const char* label, const proto::Percentiles& p) {
    std::printf("  %-12s %10.3f %10.3f\n", label, p.p50(), p.max());
  };
  std::printf("service images: %llu by written pages, %llu by fork\n",
              static_cast<unsigned long long>(ph.images_by_pages()), static_cast<unsigned long long>(ph.images_by_fork()));
  std::printf("phases:\n");
  phase("cp: snapshot", ph.checkpoint_snapshot());
  phase("cp: taken", ph.checkpoint_taken());
  phase("cp: save", ph.checkpoint_save());
  phase("rb: kill", ph.rollback_kill());
  phase("rb: resume", ph.rollback_resume());
  phase("rb: restore", ph.rollback_restore());
  std::printf("ratio cold restart / rollback (p50): %.1fx; cold restart / checkpoint (p50): %.1fx\n",
              rb.p50() > 0 ? cr.p50() / rb.p50() : 0.0, cp.p50() > 0 ? cr.p50() / cp.p50() : 0.0);
  std::printf("targets: checkpoint p50 <= 0.5 ms: %s; rollback p50 <= 0.5 ms: %s\n", cp.p50() <= 0.5 ? "met" : "NOT met",
              rb.p50() <= 0.5 ? "met" : "NOT met");
}

// `rejuv bench images GRAPH`: the cycles, then the cold restarts, on one kernel; the table (print_images).
int bench_images(const std::string& graph_path, const ImageBench& b) {
  const std::uint64_t cycles = b.cycles;
  const std::uint64_t restarts = b.restarts;
  const std::uint64_t between = b.between;
  auto loaded = launch::load_launch(graph_path);
  if (!loaded) return refuse(loaded.error().to_string());
  if (!loaded->graph.sr().enabled()) return refuse("rejuv bench images: " + graph_path + " has sr.enabled false");

  kernel::KernelOptions options;
  options.time_master = kernel::TimeMaster::Manual;
  options.no_attack = true;
  // The kernel's log goes to a temporary file, shown (its tail) only if the benchmark stops.
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> log(std::tmpfile(), &std::fclose);
  options.log = log.get();
  const auto stopped = [&] {
    if (log && std::fflush(log.get()) == 0) {
      const std::string tail = log_tail("/proc/self/fd/" + std::to_string(::fileno(log.get())), 20);
      if (!tail.empty()) std::fprintf(stderr, "the kernel's last log lines:\n%s\n", tail.c_str());
    }
    return static_cast<int>(Exit::Findings);
  };
  options.service_dir = service_dir();
  options.repo_root = REJUV_SOURCE_DIR;
  options.dds_domain = static_cast<std::uint32_t>(::getpid() % 200 + 20);  // apart from a concurrent run
  const std::string name = loaded->graph.name();
  auto created = kernel::Kernel::create(std::move(*loaded), options);
  if (!created) {
    std::fprintf(stderr, "rejuv bench: %s\n", created.error().to_string().c_str());
    return static_cast<int>(created.error().is_bad_input() ? Exit::BadInput : Exit::Findings);
  }
  kernel::Kernel& k = **created;
  if (auto ok = k.boot(); !ok) {
    std::fprintf(stderr, "rejuv bench: %s\n", ok.error().to_string().c_str());
    return stopped();
  }
  std::size_t rejuvenated = 0;
  for (std::size_t i = 0; i < k.service_count(); ++i) {
    const kernel::ServiceStats st = k.stats(ServiceId(static_cast<std::uint32_t>(i)));
    if (st.started && launch::rejuvenate(k.graph().graph.services(static_cast<int>(i)))) ++rejuvenated;
  }
  const auto step = [&](std::uint64_t ms = 1) -> bool {
    auto r = k.step(k.now() + std::chrono::milliseconds{ms});
    if (!r) std::fprintf(stderr, "rejuv bench: step: %s\n", r.error().to_string().c_str());
    return r.has_value() && !k.stop_reason();
  };
  std::fprintf(stderr,
               "rejuv bench images: %s, %zu rejuvenated services + queues; %llu cycles %llu ms apart, %llu cold restarts\n",
               name.c_str(), rejuvenated, static_cast<unsigned long long>(cycles),
               static_cast<unsigned long long>(between), static_cast<unsigned long long>(restarts));
  for (int i = 0; i < 5; ++i) {
    if (!step()) return stopped();
  }
  for (std::uint64_t c = 0; c < cycles; ++c) {
    if (auto g = k.checkpoint_now(); !g) {
      std::fprintf(stderr, "rejuv bench: checkpoint: %s\n", g.error().to_string().c_str());
      return stopped();
    }
    if (!step(between)) return stopped();
    if (auto ok = k.rollback_now(); !ok) {
      std::fprintf(stderr, "rejuv bench: rollback: %s\n", ok.error().to_string().c_str());
      return stopped();
    }
    if (!step(between)) return stopped();
    if ((c + 1) % 50 == 0) std::fprintf(stderr, "  %llu/%llu cycles\n", static_cast<unsigned long long>(c + 1),
                                        static_cast<unsigned long long>(cycles));
  }
  std::vector<double> cold;
  for (std::uint64_t r = 0; r < restarts; ++r) {
    const Nanos t0 = sys::monotonic_now();
    if (auto ok = k.rollback_now(true); !ok || k.stop_reason()) {
      std::fprintf(stderr, "rejuv bench: cold restart failed: %s\n", k.stop_detail().c_str());
      return stopped();
    }
    cold.push_back(ms_since(t0));
    if (!step()) return stopped();
  }
  print_images(k.sr_stats(), name, rejuvenated, cold);
  k.shutdown();
  return static_cast<int>(Exit::Ok);
}

}  // namespace

int run_bench(std::span<const std::string_view> args) {
  std::string what, graph_path;
  std::uint64_t cycles = 200, restarts = 20, between = 1, seconds = 20, rounds = 1, samples = 2500;
  std::uint64_t reopen_seconds = 10;
  std::optional<std::filesystem::path> out;
  bool no_link = false;
  Options opts("bench",
               "Benchmarks, side by side in one run.\n"
               "  images [GRAPH]    checkpoint and rollback of every rejuvenated service of GRAPH (default\n"
               "                    launch/quad_square_paper.launch.pbtxt) with the queue state, against a cold restart\n"
               "                    of the same services from their binaries.\n"
               "  realtime [GRAPH]  this machine's floor (rt-tests cyclictest at the control period) and GRAPH flown\n"
               "                    in real time without SR, with SR, and with SR under its attacks: the intervals\n"
               "                    between actuator outputs and those holding a checkpoint or a rollback, as ratios\n"
               "                    to the floor (docs/realtime.md), and the lockstep charge they imply (what the\n"
               "                    vehicle lost at a checkpoint and a rollback) in DIR/lockstep_charge.pbtxt.\n"
               "  across-hosts      publish -> deliver latency of a vehicle_state sample at 250 Hz between two network\n"
               "                    namespaces joined by a veth pair: raw Cyclone DDS, and with DDS Security from\n"
               "                    `rejuv keys` (tests/across_hosts/companion.launch.pbtxt), and the link's path\n"
               "                    (service > kernel > rejuv_host_link > DDS > link > kernel > service, two\n"
               "                    `rejuv run --host` kernels), as ratios; then, with SR, the time from each\n"
               "                    CP -> MC (the link reopened) until the first sample crosses (root only).");
  opts.positional("WHAT", what, "what to measure: images, realtime or across-hosts")
      .positional("GRAPH", graph_path, "the launch graph (default: launch/quad_square_paper.launch.pbtxt)", false)
      .integer("--cycles", "N", cycles, {1, 100000}, "checkpoint + rollback cycles")
      .integer("--restarts", "N", restarts, {1, 1000}, "cold restarts")
      .integer("--between", "MS", between, {1, 10000},
               "simulated ms between a checkpoint and its rollback and between a rollback and the next checkpoint\n"
               "(1: the next one comes while the images are still being made; a mission has seconds)");
  opts.integer("--seconds", "N", seconds, {2, 3600}, "realtime: seconds of each flight and of the floor")
      .integer("--rounds", "N", rounds, {1, 100},
               "realtime: fly the configurations N times, alternated, and pool each one's intervals (a shared\n"
               "machine's slow spells then fall on all of them alike); across-hosts: the rows likewise")
      .path("--out", "DIR", out,
            "realtime: where the flights' files and cyclictest's histograms go; across-hosts: the keystore, the\n"
            "peers' configs and logs, latency.csv, reopen.csv (each MC window of the flight with SR)",
            "a new temporary folder")
      .integer("--samples", "N", samples, {100, 1'000'000}, "across-hosts: samples per row and round")
      .integer("--reopen-seconds", "N", reopen_seconds, {2, 600},
               "across-hosts: seconds of the flight with SR whose CP -> MC are measured (the square in real time: an\n"
               "MC window of 0.2 s every 0.4 to 1.3 s)")
      .flag("--no-link", no_link,
            "across-hosts: leave out the link's rows (two flights of two `rejuv run --host` kernels, ~1 min each)");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (what == "realtime") return run_bench_realtime(graph_path, seconds, rounds, out);
  if (what == "across-hosts") {
    if (!graph_path.empty()) return refuse("rejuv bench across-hosts: takes no GRAPH (its graph is tests/across_hosts')");
    return run_bench_across_hosts(AcrossHostsBench{.samples = samples,
                                                   .rounds = rounds,
                                                   .reopen_seconds = reopen_seconds,
                                                   .out = out,
                                                   .link = no_link ? LinkRow::Skip : LinkRow::Measure});
  }
  if (what != "images") {
    return refuse("rejuv bench: unknown benchmark '" + what + "' (known: images, realtime, across-hosts)");
  }
  if (graph_path.empty()) graph_path = std::string(REJUV_SOURCE_DIR) + "/launch/quad_square_paper.launch.pbtxt";
  return bench_images(graph_path, ImageBench{.cycles = cycles, .restarts = restarts, .between = between});
}

}  // namespace rejuv::cli
