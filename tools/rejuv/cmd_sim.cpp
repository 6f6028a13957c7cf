// `rejuv sim GRAPH`: the model-level SR simulation (DESIGN §8–§9) in one process, no runtime. Prints a
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
#include "figures.hpp"
#include "attack_option.hpp"
#include "report.hpp"
#include "commands.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using UniqueFile = std::unique_ptr<std::FILE, FileCloser>;

void print(std::FILE* to, const std::string& text) { std::fputs(text.c_str(), to); }

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

}  // namespace

int run_sim(std::span<const std::string_view> args) {
  std::string graph_path, seed_text, json_path, csv_path, out_text, trace_text = "compact", attack_text;
  bool attack_set = false;
  bool no_sr = false, no_attack = false, table = false, seed_set = false, json_set = false, csv_set = false;
  bool out_set = false, trace_set = false, no_figures = false;
  ArgParser parser("sim",
                   "Model-level simulation of the CPS SR scheme (paper §II, §IV–§VI) in one process: plant at 1 kHz,\n"
                   "sensors, EKF, LQR controllers, the modes MC/RB/SC/update/CP and the worst-case attack of §VI-D.\n"
                   "Exit 0 when the mission completes inside the safety set, 1 when it fails or leaves it\n"
                   "(--table: 0 once all four configurations ran), 2 on bad flags or a bad launch file.");
  parser.positional("GRAPH", graph_path, "the launch graph (*.launch.pbtxt): sr, mission, plant, attack")
      .flag("--no-sr", no_sr, "no rejuvenation: the same tracking algorithm in MC for the whole mission")
      .flag("--no-attack", no_attack, "disable the attack plan")
      .option("--attack", "KIND", attack_text, kAttackOptionHelp, &attack_set)
      .option("--seed", "N", seed_text, "seed of sensor noise and wind (default: the graph's seed)", &seed_set)
      .option("--summary-json", "FILE", json_path, "write the RunSummary as JSON (--table: an array of four)",
              &json_set)
      .option("--csv", "FILE", csv_path, "write a trace: t, x, x_hat, x_sp, mode, u, V every control period",
              &csv_set)
      .option("--out", "DIR", out_text, kOutHelp, &out_set)
      .option("--trace", "compact|full", trace_text, kTraceHelp, &trace_set)
      .flag("--no-figures", no_figures, kNoFiguresHelp)
      .flag("--table", table, "run Table I: SR on/off x attack on/off, and print the comparison");
  const auto parsed = parser.parse(args);
  if (!parsed) return bad_input("rejuv sim: " + parsed.error());
  switch (*parsed) {
    case ParseOutcome::HelpShown: print(stdout, parser.help()); return static_cast<int>(Exit::Ok);
    case ParseOutcome::Run: break;
  }
  flight::SimOverrides overrides;
  if (seed_set) {
    const auto seed = to_u64(seed_text, "--seed");
    if (!seed) return bad_input("rejuv sim: " + seed.error());
    overrides.seed = *seed;
  }
  if (table && (no_sr || no_attack || csv_set || out_set)) {
    return bad_input("rejuv sim: --table runs all four configurations; it cannot be combined with --no-sr, "
                     "--no-attack, --csv or --out");
  }
  const auto trace_detail = parse_trace_detail(trace_text);
  if (!trace_detail) return bad_input("rejuv sim: " + trace_detail.error());
  if (trace_set && !out_set) return bad_input("rejuv sim: --trace is the detail of --out's trace: give --out DIR");
  if (no_figures && !out_set) return bad_input("rejuv sim: --no-figures goes with --out DIR");
  if (no_sr) overrides.sr = flight::SrSwitch::Off;
  if (no_attack) overrides.attack = flight::AttackSwitch::Off;

  auto loaded = launch::load_launch(graph_path);
  if (!loaded) return bad_input(loaded.error().to_string());
  if (attack_set) {
    auto ok = apply_attack_option(*loaded, attack_text);
    if (!ok) return bad_input("rejuv sim: " + ok.error());
  }
  auto config = flight::config_from_launch(*loaded, overrides);
  if (!config) return bad_input(config.error().to_string());

  // Open every output before the (long) run, so a bad path fails fast.
  UniqueFile json_file, csv_file;
  if (json_set) {
    json_file.reset(std::fopen(json_path.c_str(), "w"));
    if (!json_file) return bad_input("rejuv sim: cannot write --summary-json file '" + json_path + "'");
  }
  if (csv_set) {
    csv_file.reset(std::fopen(csv_path.c_str(), "w"));
    if (!csv_file) return bad_input("rejuv sim: cannot write --csv file '" + csv_path + "'");
  }
  std::optional<RunFiles> files;
  if (out_set) {
    auto opened = RunFiles::open(out_text, *trace_detail);
    if (!opened) return bad_input("rejuv sim: " + opened.error());
    files.emplace(std::move(*opened));
  }
  const bool tty = isatty(STDERR_FILENO) == 1;

  if (!table) {
    flight::SimObservers obs = progress_observers(config->graph_name, tty);
    if (csv_file) write_trace_header(csv_file.get());
    if (csv_file || files) {
      obs.trace = [f = csv_file.get(), out = files ? &*files : nullptr](const flight::TraceRow& r) {
        if (f != nullptr) write_trace_row(f, r);
        if (out != nullptr) out->trace(r);
      };
    }
    if (files) {
      obs.control_update = [out = &*files](Nanos t, Nanos wall) { out->control_update(t, wall); };
      obs.sr_event = [out = &*files](const SrEvent& e) { out->sr_event(e); };
    }
    auto summary = flight::run_simulation(*config, obs);
    if (!summary) return bad_input("rejuv sim: " + summary.error().to_string());
    const bool out_ok = !files || finish_out_dir(*files, *summary, "rejuv sim", no_figures ? Figures::Skip : Figures::Draw);
    print(stdout, describe(*summary));
    if (json_file) print(json_file.get(), to_json(*summary) + "\n");
    return static_cast<int>(run_is_good(*summary) && out_ok ? Exit::Ok : Exit::Findings);
  }

  // Table I (§VI-D): the four configurations, same seed, same tracking algorithm.
  struct Row {
    const char* label;
    flight::SrSwitch sr;
    flight::AttackSwitch attack;
  };
  const Row rows[] = {{"no SR, no attack", flight::SrSwitch::Off, flight::AttackSwitch::Off},
                      {"SR, no attack", flight::SrSwitch::On, flight::AttackSwitch::Off},
                      {"no SR, attack", flight::SrSwitch::Off, flight::AttackSwitch::On},
                      {"SR, attack", flight::SrSwitch::On, flight::AttackSwitch::On}};
  std::vector<proto::RunSummary> results;
  for (const Row& row : rows) {
    flight::SimConfig c = *config;
    c.sr = row.sr;
    c.attack.enabled = row.attack;
    const auto summary = flight::run_simulation(c, progress_observers(row.label, tty));
    if (!summary) return bad_input("rejuv sim: " + summary.error().to_string());
    results.push_back(*summary);
  }
  std::string out = "Table I (" + config->graph_name + ", seed " + std::to_string(config->seed) + ")\n";
  char line[512];
  std::snprintf(line, sizeof line, "%-18s %9s %10s %9s %9s %10s %8s  %s\n", "configuration", "d_mean", "d_max",
                "T", "max V", "rollbacks", "attacks", "outcome");
  out += line;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const proto::RunSummary& s = results[i];
    std::string outcome = s.mission_completed() ? "completed" : "NOT COMPLETED";
    if (s.left_safety_set()) outcome += ", LEFT SAFETY SET";
    std::snprintf(line, sizeof line, "%-18s %6.2f cm %7.2f cm %7.1f s %9.4f %10llu %8llu  %s\n", rows[i].label,
                  100.0 * s.d_mean_m(), 100.0 * s.d_max_m(), s.mission_time_s(), s.max_v(),
                  static_cast<unsigned long long>(s.rollbacks()), static_cast<unsigned long long>(s.attacks()),
                  outcome.c_str());
    out += line;
  }
  print(stdout, out);
  if (json_file) {
    std::string array = "[\n";
    for (std::size_t i = 0; i < results.size(); ++i) array += (i > 0 ? ",\n" : "") + to_json(results[i]);
    print(json_file.get(), array + "]\n");
  }
  return static_cast<int>(Exit::Ok);
}

}  // namespace rejuv::cli
