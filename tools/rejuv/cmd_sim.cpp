// `rejuv sim GRAPH`: the model-level SR simulation (docs/design.md §8–§9) in one process, no runtime. Prints a
// summary (or, with --table, the four configurations of Table I, §VI-D), writes the RunSummary as JSON and a
// CSV trace on request. Exit 0 when the mission completes inside the safety set, 1 when it fails or leaves the
// safety set (under --table: 0 once all four ran), 2 on bad flags or a bad launch file.
#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "args.hpp"
#include "common_options.hpp"
#include "figures.hpp"
#include "attack_option.hpp"
#include "report.hpp"
#include "commands.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {
namespace {

std::string describe(const proto::RunSummary& s) {
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "%s: sr=%s attack=%s seed=%llu\n"
                "  mission     %s in %.1f s (simulated %.1f s, %.0fx real time)\n"
                "  tracking    d_mean %.2f cm, d_max %.2f cm\n"
                "  safety      max V = %.4f (%s), max estimation error ||x - x_hat||^2_P = %.4f\n"
                "  SR          %llu rollbacks, %llu checkpoints, %llu attacked MC windows, max control gap %.1f ms\n",
                s.graph().c_str(), s.sr() ? "on" : "off", s.attack() ? (s.attack_kind().empty() ? "on" : s.attack_kind().c_str()) : "off",
                static_cast<unsigned long long>(s.seed()), s.mission_completed()       ? "completed"
                : s.stopped_after_attacks() ? "stopped after the attacks (stop_after_attacks)"
                                            : "NOT COMPLETED",
                s.mission_time_s(), s.sim_time_s(), s.realtime_factor(), 100.0 * s.d_mean_m(), 100.0 * s.d_max_m(),
                s.max_v(), s.left_safety_set() ? "LEFT THE SAFETY SET" : "safe",
                s.max_est_err_p(), static_cast<unsigned long long>(s.rollbacks()),
                static_cast<unsigned long long>(s.checkpoints()), static_cast<unsigned long long>(s.attacks()),
                s.max_control_gap_ms());
  return buf;
}

// Progress on stderr: periodic lines only on a terminal (logs stay clean), the final line always.
flight::SimObservers progress_observers(const std::string& label, bool tty) {
  flight::SimObservers obs;
  obs.progress = [label, tty](const flight::ProgressReport& p) {
    if (!tty && !p.final) return;
    std::fprintf(stderr, "rejuv sim: %s%s t = %6.1f s  path %3.0f%%  mode %s  rollbacks %llu  max V %.3f  (%.1f s wall)\n",
                 label.c_str(), p.final ? " done:" : "", p.sim_time.count(), 100.0 * p.path_progress,
                 mode_name(p.mode), static_cast<unsigned long long>(p.rollbacks), p.max_V, p.wall_time.count());
  };
  return obs;
}

bool run_is_good(const proto::RunSummary& s) {
  return (s.mission_completed() || s.stopped_after_attacks()) && !s.left_safety_set();
}

// What `rejuv sim` was asked for.
struct SimRequest {
  std::string graph_path;
  std::optional<std::uint64_t> seed;
  FlightSwitches switches;
  std::optional<std::filesystem::path> json_path, csv_path;
  OutFlags files_out;
  bool table = false;
};

void declare_sim_options(Options& opts, SimRequest& r) {
  opts.positional("GRAPH", r.graph_path, "the launch graph (*.launch.pbtxt): sr, mission, plant, attack");
  flight_options(opts, r.switches, "no rejuvenation: the same tracking algorithm in MC for the whole mission");
  seed_option(opts, r.seed, "seed of sensor noise and wind")
      .path("--summary-json", "FILE", r.json_path, "write the RunSummary as JSON (--table: an array of four)")
      .path("--csv", "FILE", r.csv_path, "write a trace: t, x, x_hat, x_sp, mode, u, V every control period");
  out_options(opts, r.files_out).flag("--table", r.table, "run Table I: SR on/off x attack on/off, and print the comparison");
}

// Where the run's results go, every file opened before the (long) run so that a bad path fails fast.
struct SimOutputs {
  UniqueFile json, csv;
  std::optional<RunFiles> files;  // --out DIR
};

Result<SimOutputs, std::string> open_sim_outputs(const SimRequest& r) {
  SimOutputs out;
  if (auto opened = open_outputs("rejuv sim", r.json_path, r.csv_path, out.json, out.csv); !opened) {
    return fail(opened.error());
  }
  if (r.files_out.dir) {
    auto opened = RunFiles::open(*r.files_out.dir, r.files_out.trace);
    if (!opened) return fail("rejuv sim: " + opened.error());
    out.files.emplace(std::move(*opened));
  }
  return out;
}

// One flight: progress, the trace to --csv and --out, the summary printed and written.
int fly_one(const SimRequest& r, const flight::SimConfig& config, SimOutputs& out, bool tty) {
  flight::SimObservers obs = progress_observers(config.graph_name, tty);
  if (out.csv) write_trace_header(out.csv.get());
  RunFiles* files = out.files ? &*out.files : nullptr;
  if (out.csv || files != nullptr) {
    obs.trace = [f = out.csv.get(), files](const flight::TraceRow& row) {
      if (f != nullptr) write_trace_row(f, row);
      if (files != nullptr) files->trace(row);
    };
  }
  if (files != nullptr) {
    obs.control_update = [files](Nanos t, Nanos wall) { files->control_update(t, wall); };
    obs.sr_event = [files](const SrEvent& e) { files->sr_event(e); };
  }
  auto summary = flight::run_simulation(config, obs);
  if (!summary) return refuse("sim", summary.error().to_string());
  const bool out_ok = files == nullptr ||
                      finish_out_dir(*files, *summary, "rejuv sim", r.files_out.no_figures ? Figures::Skip : Figures::Draw);
  print(stdout, describe(*summary));
  if (out.json) print(out.json.get(), to_json(*summary) + "\n");
  return static_cast<int>(run_is_good(*summary) && out_ok ? Exit::Ok : Exit::Findings);
}

// Table I (§VI-D): the four configurations, same seed, same tracking algorithm.
struct TableRow {
  const char* label;
  flight::SrSwitch sr;
  flight::AttackSwitch attack;
};
constexpr TableRow kTableRows[] = {{"no SR, no attack", flight::SrSwitch::Off, flight::AttackSwitch::Off},
                                   {"SR, no attack", flight::SrSwitch::On, flight::AttackSwitch::Off},
                                   {"no SR, attack", flight::SrSwitch::Off, flight::AttackSwitch::On},
                                   {"SR, attack", flight::SrSwitch::On, flight::AttackSwitch::On}};

std::string table_text(const flight::SimConfig& config, const std::vector<proto::RunSummary>& results) {
  std::string out = "Table I (" + config.graph_name + ", seed " + std::to_string(config.seed) + ")\n";
  char line[512];
  std::snprintf(line, sizeof line, "%-18s %9s %10s %9s %9s %10s %8s  %s\n", "configuration", "d_mean", "d_max",
                "T", "max V", "rollbacks", "attacks", "outcome");
  out += line;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const proto::RunSummary& s = results[i];
    std::string outcome = s.mission_completed() ? "completed" : "NOT COMPLETED";
    if (s.left_safety_set()) outcome += ", LEFT SAFETY SET";
    std::snprintf(line, sizeof line, "%-18s %6.2f cm %7.2f cm %7.1f s %9.4f %10llu %8llu  %s\n", kTableRows[i].label,
                  100.0 * s.d_mean_m(), 100.0 * s.d_max_m(), s.mission_time_s(), s.max_v(),
                  static_cast<unsigned long long>(s.rollbacks()), static_cast<unsigned long long>(s.attacks()),
                  outcome.c_str());
    out += line;
  }
  return out;
}

// The four flights of Table I, printed side by side (and written as a JSON array).
int fly_table(const flight::SimConfig& config, const SimOutputs& out, bool tty) {
  std::vector<proto::RunSummary> results;
  for (const TableRow& row : kTableRows) {
    flight::SimConfig c = config;
    c.sr = row.sr;
    c.attack.enabled = row.attack;
    const auto summary = flight::run_simulation(c, progress_observers(row.label, tty));
    if (!summary) return refuse("sim", summary.error().to_string());
    results.push_back(*summary);
  }
  print(stdout, table_text(config, results));
  if (out.json) {
    std::string array = "[\n";
    for (std::size_t i = 0; i < results.size(); ++i) array += (i > 0 ? ",\n" : "") + to_json(results[i]);
    print(out.json.get(), array + "]\n");
  }
  return static_cast<int>(Exit::Ok);
}

}  // namespace

int run_sim(std::span<const std::string_view> args) {
  SimRequest r;
  Options opts("sim",
               "Model-level simulation of the CPS SR scheme (paper §II, §IV–§VI) in one process: plant at 1 kHz,\n"
               "sensors, EKF, LQR controllers, the modes MC/RB/SC/update/CP and the worst-case attack of §VI-D.\n"
               "Exit 0 when the mission completes inside the safety set, 1 when it fails or leaves it\n"
               "(--table: 0 once all four configurations ran), 2 on bad flags or a bad launch file.");
  declare_sim_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.table && (r.switches.no_sr || r.switches.no_attack || r.csv_path || r.files_out.dir)) {
    return refuse("sim", "--table runs all four configurations; it cannot be combined with --no-sr, --no-attack, "
                         "--csv or --out");
  }
  if (auto ok = check_out_options(opts, r.files_out); !ok) return refuse("sim", ok.error());
  flight::SimOverrides overrides;
  overrides.seed = r.seed;
  if (r.switches.no_sr) overrides.sr = flight::SrSwitch::Off;
  if (r.switches.no_attack) overrides.attack = flight::AttackSwitch::Off;
  auto loaded = load_with_attack(r.graph_path, r.switches.attack, "rejuv sim");
  if (!loaded) return refuse(loaded.error());
  auto config = flight::config_from_launch(*loaded, overrides);
  if (!config) return refuse(config.error().to_string());
  auto out = open_sim_outputs(r);
  if (!out) return refuse(out.error());
  const bool tty = isatty(STDERR_FILENO) == 1;
  return r.table ? fly_table(*config, *out, tty) : fly_one(r, *config, *out, tty);
}

}  // namespace rejuv::cli
