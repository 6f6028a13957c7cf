// `rejuv bench realtime [GRAPH] [--seconds N] [--out DIR]` (docs/realtime.md): what a
// vehicle sees of Rejuv in real time, beside this machine's floor, measured in one go.
//
// 1. The floor: Debian's rt-tests `cyclictest` at the control period (one thread, mlockall), as SCHED_OTHER —
//    the policy of every process of a run today — and, where the user may, SCHED_FIFO 80: its wake-up latency
//    histogram gives what a periodic task on this machine gets at best.
// 2. The graph flown in real time (`rejuv run GRAPH --realtime --duration N --out …`, each a child process, as
//    a user would run it): without SR, with SR and no attack, with SR and the graph's attacks. From each run's
//    control.csv: every interval between two actuator outputs (wall clock), and those holding a checkpoint or a
//    rollback.
// One table, each run's intervals as a ratio to the floor's interval (the period plus the floor's latency), and
// the lockstep charge these runs imply (DIR/lockstep_charge.pbtxt: what the vehicle lost at a checkpoint and at
// a rollback, for the launch file's `lockstep`).
// Nothing here is asserted: a shared VM is noisy, the table says what it saw.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/process.hpp"
#include "report.hpp"
#include "run_child.hpp"

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;

constexpr int kPeriodUs = 4000;  // the control period of the in-tree graphs (250 Hz)

// Percentiles of a sample [ms]; NaN when empty.
struct Spread {
  std::size_t n = 0;
  double p50 = 0, p99 = 0, p999 = 0, max = 0;
};

Spread spread_of(std::vector<double> v) {
  Spread s;
  s.n = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
  s.p50 = at(0.5);
  s.p99 = at(0.99);
  s.p999 = at(0.999);
  s.max = v.back();
  return s;
}

// The floor: cyclictest's latency histogram [µs] → the intervals a periodic task gets [ms].
struct Floor {
  std::string policy;
  Spread interval;  // period + latency
  std::string error{};
};

Floor cyclictest(const std::string& policy, int priority, int seconds, const fs::path& dir) {
  Floor f{.policy = policy, .interval = {}, .error = {}};
  const fs::path hist = dir / ("cyclictest_" + policy + ".hist");
  const fs::path log = dir / ("cyclictest_" + policy + ".log");
  const sys::UniqueFd log_fd(::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  const sys::UniqueFd null_fd(::open("/dev/null", O_RDONLY | O_CLOEXEC));
  if (!log_fd || !null_fd) {
    f.error = "cannot write " + log.string();
    return f;
  }
  sys::SpawnSpec spec;
  spec.executable = "/usr/bin/cyclictest";
  if (!fs::exists(spec.executable)) {
    f.error = "no /usr/bin/cyclictest (Debian package rt-tests; ./rejuv build installs it)";
    return f;
  }
  spec.args = {"-q", "-m", "-t", "1", "-i", std::to_string(kPeriodUs), "-p", std::to_string(priority),
               "-D", std::to_string(seconds), "-h", "50000", "--histfile=" + hist.string()};
  for (char** e = environ; *e != nullptr; ++e) spec.env.emplace_back(*e);
  spec.fds = {{0, null_fd.get()}, {1, log_fd.get()}, {2, log_fd.get()}};
  auto child = sys::spawn(spec);
  if (!child) {
    f.error = "cannot start cyclictest: " + child.error().to_string();
    return f;
  }
  auto status = child->wait();
  if (!status || !status->success()) {
    f.error = "cyclictest " + (status ? status->to_string() : status.error().to_string()) + " (see " + log.string() + ")";
    return f;
  }
  // "latency_us count" lines, '#' comments.
  std::ifstream in(hist);
  std::vector<double> ms;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    long us = 0;
    long count = 0;
    if (!(fields >> us >> count) || count <= 0) continue;
    ms.insert(ms.end(), static_cast<std::size_t>(count), (kPeriodUs + static_cast<double>(us)) / 1000.0);
  }
  if (ms.empty()) f.error = "cyclictest wrote no histogram (" + hist.string() + ")";
  f.interval = spread_of(std::move(ms));
  return f;
}

// One configuration's intervals [ms], pooled over its rounds (every interval, those holding a CP, a RB).
struct Intervals {
  std::vector<double> all, cp, rb;
};

struct Flight {
  std::string label;
  Spread all, cp, rb;
  std::string error{};
};

// One `rejuv run --realtime` into DIR/<name>: its control.csv's intervals added to `into`; an error otherwise.
std::optional<std::string> fly(const std::string& name, const std::string& graph, int seconds,
                               const std::vector<std::string>& extra, const fs::path& dir, Intervals& into) {
  const fs::path out = dir / name;
  std::vector<std::string> args{graph, "--realtime", "--duration", std::to_string(seconds), "--out", out.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  auto child = start_rejuv_run(args, dir / (name + ".log"));
  if (!child) return child.error();
  auto status = child->wait();
  // Exit 1 (left the safety set, not completed in the duration) still has a control.csv worth reading.
  if (!status || (status->how != sys::ExitStatus::How::Exited) || status->value > 1) {
    return "rejuv run " + (status ? status->to_string() : status.error().to_string()) + ": " +
           log_tail(dir / (name + ".log"), 3);
  }
  std::ifstream in(out / "control.csv");
  std::string line;
  std::getline(in, line);  // t_s,wall_s,interval_ms,wall_interval_ms,mark,wall_mark
  std::size_t read = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string c; std::getline(row, c, ',');) cells.push_back(c);
    if (cells.size() < 4) continue;
    const double ms = std::strtod(cells[3].c_str(), nullptr);
    into.all.push_back(ms);
    ++read;
    const std::string mark = cells.size() > 5 ? cells[5] : "";
    if (mark == "CP") into.cp.push_back(ms);
    if (mark == "RB") into.rb.push_back(ms);
  }
  if (read == 0) return "no control updates in " + (out / "control.csv").string();
  return std::nullopt;
}

// The flights: each configuration `rounds` times, the configurations alternated within each round (so that
// the machine's slow spells, which come and go over minutes on a shared VM, fall on all of them alike), and
// each configuration's intervals pooled over its rounds.
std::vector<Flight> fly_rounds(const std::vector<std::pair<std::string, std::vector<std::string>>>& plan,
                               const std::string& graph, int seconds, int rounds, const fs::path& dir) {
  std::vector<Intervals> pooled(plan.size());
  std::vector<Flight> flights;
  for (const auto& entry : plan) flights.push_back(Flight{.label = entry.first, .all = {}, .cp = {}, .rb = {}});
  for (int r = 1; r <= rounds; ++r) {
    for (std::size_t i = 0; i < plan.size(); ++i) {
      Flight& f = flights[i];
      if (!f.error.empty()) continue;
      const std::string name = rounds > 1 ? f.label + "_" + std::to_string(r) : f.label;
      std::fprintf(stderr, "  rejuv run --realtime (%s", f.label.c_str());
      if (rounds > 1) std::fprintf(stderr, ", round %d of %d", r, rounds);
      std::fprintf(stderr, ") …\n");
      if (auto error = fly(name, graph, seconds, plan[i].second, dir, pooled[i])) f.error = *error;
    }
  }
  for (std::size_t i = 0; i < plan.size(); ++i) {
    flights[i].all = spread_of(std::move(pooled[i].all));
    flights[i].cp = spread_of(std::move(pooled[i].cp));
    flights[i].rb = spread_of(std::move(pooled[i].rb));
  }
  return flights;
}

using FlightPlan = std::vector<std::pair<std::string, std::vector<std::string>>>;  // label, `rejuv run` flags

// The floor: cyclictest under SCHED_OTHER, and (as root) SCHED_FIFO 80.
std::vector<Floor> measure_floors(int seconds, const fs::path& dir) {
  std::vector<Floor> floors;
  std::fprintf(stderr, "  cyclictest SCHED_OTHER …\n");
  floors.push_back(cyclictest("SCHED_OTHER", 0, seconds, dir));
  if (::geteuid() == 0) {
    std::fprintf(stderr, "  cyclictest SCHED_FIFO 80 …\n");
    floors.push_back(cyclictest("SCHED_FIFO_80", 80, seconds, dir));
  }
  return floors;
}

// The configurations to fly. The baseline flies neither SR nor the attacks: without SR nothing ends an attack
// (the square under its worst-case attack leaves the safety set within two seconds), and the bound of
// docs/realtime.md compares against a whole flight of the undisturbed chain.
FlightPlan flight_plan(const proto::Launch& graph) {
  const bool sr = graph.sr().enabled();
  const bool attack = graph.attack().enabled() && graph.attack().attacks_size() > 0;
  FlightPlan plan{{"no_sr", {"--no-sr", "--no-attack"}}};
  if (sr) plan.push_back({"sr", {"--no-attack"}});
  if (sr && attack) plan.push_back({"sr_attack", {}});
  return plan;
}

// The table: the floors, then each flight with its ratios to the floor and to the baseline (no_sr).
void print_table(const std::string& graph, int seconds, std::uint64_t rounds, const std::vector<Floor>& floors,
                 const std::vector<Flight>& flights) {
  const Floor& floor = floors.front();
  std::printf("rejuv bench realtime: %s, %d s each, %llu round%s, control period %.1f ms\n", graph.c_str(), seconds,
              static_cast<unsigned long long>(rounds), rounds == 1 ? "" : "s", kPeriodUs / 1000.0);
  std::printf("%-26s %7s %7s %7s %7s %8s %9s | %-20s | %-20s\n", "intervals [ms]", "p50", "p99", "p99.9", "max",
              "p99.9/fl", "/no SR", "holding a CP p50/max", "holding a RB p50/max");
  for (const Floor& f : floors) {
    if (!f.error.empty()) {
      std::printf("%-26s %s\n", ("floor " + f.policy).c_str(), f.error.c_str());
      continue;
    }
    std::printf("%-26s %7.2f %7.2f %7.2f %7.2f %8s %9s | %-20s | %-20s\n",
                ("floor (cyclictest " + f.policy + ")").c_str(), f.interval.p50, f.interval.p99, f.interval.p999,
                f.interval.max, "1.00", "", "", "");
  }
  const Flight& baseline = flights.front();  // no_sr
  for (const Flight& f : flights) {
    if (!f.error.empty()) {
      std::printf("%-26s %s\n", f.label.c_str(), f.error.c_str());
      continue;
    }
    char ratio[32] = "-";
    if (floor.error.empty() && floor.interval.p999 > 0) std::snprintf(ratio, sizeof ratio, "%.2f", f.all.p999 / floor.interval.p999);
    char to_baseline[32] = "-";
    if (baseline.error.empty() && baseline.all.p999 > 0) {
      std::snprintf(to_baseline, sizeof to_baseline, "%.2f", f.all.p999 / baseline.all.p999);
    }
    char cp[48] = "-";
    char rb[48] = "-";
    if (f.cp.n > 0) std::snprintf(cp, sizeof cp, "%.2f / %.2f (%zu)", f.cp.p50, f.cp.max, f.cp.n);
    if (f.rb.n > 0) std::snprintf(rb, sizeof rb, "%.2f / %.2f (%zu)", f.rb.p50, f.rb.max, f.rb.n);
    std::printf("%-26s %7.2f %7.2f %7.2f %7.2f %8s %9s | %-20s | %-20s\n", ("rejuv run " + f.label).c_str(),
                f.all.p50, f.all.p99, f.all.p999, f.all.max, ratio, to_baseline, cp, rb);
  }
  std::printf("(%zu intervals per flight configuration; /no SR: the p99.9 as a ratio to the flight without SR and "
              "without attacks, bound 1.5 in docs/realtime.md)\n",
              baseline.all.n);
}

// What the vehicle loses at a checkpoint or a rollback, beside what lockstep charges for it (the launch file's
// lockstep.checkpoint_charge_ms / rollback_charge_ms model the interval's excess); the larger of the SR runs'
// losses [ms] written to DIR/lockstep_charge.pbtxt as the charge to model. An error when it cannot be written.
Result<void, std::string> derive_charge(const std::string& graph, int seconds, const proto::LockstepTiming& lt,
                                        const std::vector<Flight>& flights, const fs::path& dir) {
  const double period = kPeriodUs / 1000.0;
  std::optional<std::pair<double, double>> lost;
  for (const Flight& f : flights) {
    if (!f.error.empty() || f.cp.n == 0 || f.label == "no_sr") continue;
    const double at_cp = std::max(0.0, f.cp.p50 - period);
    const double at_rb = f.rb.n > 0 ? std::max(0.0, f.rb.p50 - period) : 0.0;
    lost = std::pair(std::max(at_cp, lost ? lost->first : 0.0), std::max(at_rb, lost ? lost->second : 0.0));
    std::printf("%-26s the vehicle lost %.2f ms at a checkpoint, %.2f ms at a rollback (interval p50 minus the %.1f ms "
                "period); lockstep charges %.2f / %.2f ms\n",
                ("rejuv run " + f.label).c_str(), at_cp, at_rb, period, 1000.0 * launch::checkpoint_charge(lt).count(),
                1000.0 * launch::rollback_charge(lt).count());
  }
  if (!lost) return {};
  // docs/performance.md "Deterministic lockstep": lockstep charges what the vehicle loses in real time, not the
  // timed part (the timed part runs in the slack of the control period and is mostly hidden from it).
  const auto up = [](double ms) { return std::ceil(ms * 100.0) / 100.0; };  // to 0.01 ms, never below
  const fs::path charge = dir / "lockstep_charge.pbtxt";
  std::ofstream file(charge);
  file << "# What the vehicle lost at a checkpoint and at a rollback in real time on this machine\n"
          "# (`rejuv bench realtime " << graph << " --seconds " << seconds << "`): the interval holding one, p50,\n"
          "# minus the " << period << " ms control period, the larger of the runs with SR, rounded up to 0.01 ms.\n"
          "# Set these two fields in the launch file's own `lockstep` block (keep its alignment_s) so that\n"
          "# lockstep charges what this runtime costs the vehicle\n"
          "# (docs/performance.md \"Deterministic lockstep\").\n"
       << "lockstep {\n  checkpoint_charge_ms: " << up(lost->first) << "\n  rollback_charge_ms: " << up(lost->second)
       << "\n}\n";
  file.close();
  if (!file) return fail("cannot write " + charge.string());
  std::printf("lockstep charge derived from these runs: checkpoint %.2f ms, rollback %.2f ms (%s)\n", up(lost->first),
              up(lost->second), charge.c_str());
  return {};
}

}  // namespace

int run_bench_realtime(const std::string& graph_arg, std::uint64_t seconds, std::uint64_t rounds,
                       const std::optional<fs::path>& out_dir) {
  const std::string graph = graph_arg.empty() ? std::string(REJUV_SOURCE_DIR) + "/launch/quad_square_paper.launch.pbtxt" : graph_arg;
  auto loaded = launch::load_launch(graph);
  if (!loaded) return refuse(loaded.error().to_string());
  if (!loaded->graph.has_plant()) return refuse("rejuv bench realtime: " + graph + " has no plant (no vehicle to measure)");
  std::error_code ec;
  const fs::path dir = out_dir.value_or(fs::temp_directory_path(ec) / ("rejuv-bench-realtime-" + std::to_string(::getpid())));
  fs::create_directories(dir, ec);
  if (ec) return refuse("rejuv bench realtime: --out: cannot create '" + dir.string() + "': " + ec.message());
  const int s = static_cast<int>(seconds);
  std::fprintf(stderr, "rejuv bench realtime: %s, %d s each: the floor (cyclictest), then the flights in real time "
               "(%llu round%s); files in %s\n", graph.c_str(), s, static_cast<unsigned long long>(rounds),
               rounds == 1 ? "" : "s", dir.c_str());
  const std::vector<Floor> floors = measure_floors(s, dir);
  const std::vector<Flight> flights = fly_rounds(flight_plan(loaded->graph), graph, s, static_cast<int>(rounds), dir);
  print_table(graph, s, rounds, floors, flights);
  if (auto written = derive_charge(graph, s, loaded->graph.lockstep(), flights, dir); !written) {
    std::fprintf(stderr, "rejuv bench realtime: %s\n", written.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  const bool failed = std::any_of(flights.begin(), flights.end(), [](const Flight& f) { return !f.error.empty(); });
  return static_cast<int>(failed ? Exit::Findings : Exit::Ok);
}

}  // namespace rejuv::cli
