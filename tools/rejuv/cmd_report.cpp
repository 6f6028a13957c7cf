// `rejuv report table GRAPH`: Table I of the paper (§VI-D) for the four configurations (SR on/off × attack
// on/off), each row the multi-process runtime (`rejuv run`, one real mission per row: kernel, plant over DDS,
// one process per service, lockstep) beside the model-level simulation (`rejuv sim`) for the same graph and
// seed. The runtime rows are flown by `rejuv run` itself, as child processes of this one, so that they are
// exactly what a user gets from `rejuv run` (summary, metrics, exit code); their summaries, traces and logs
// go to --out. Exit 0 once every row ran, 1 when a runtime mission could not be run (or was interrupted), 2 on
// bad input.
#include <google/protobuf/util/json_util.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "args.hpp"
#include "common_options.hpp"
#include "figures.hpp"
#include "attack_option.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "run_child.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;

// One configuration of Table I.
struct Row {
  const char* label;
  const char* key;  // file names under --out
  bool sr;
  bool attack;
};
constexpr Row kRows[] = {{"no SR, no attack", "nosr_noattack", false, false},
                         {"SR, no attack", "sr_noattack", true, false},
                         {"no SR, attack", "nosr_attack", false, true},
                         {"SR, attack", "sr_attack", true, true}};

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

struct Mission {
  std::optional<proto::RunSummary> summary{};  // nullopt: the run failed to produce one
  std::string problem{};                     // why not
  bool interrupted = false;
};

// Flies one row with `rejuv run` (this executable) and reads back its summary.
Mission fly(const Row& row, const std::string& graph, std::uint64_t seed, std::optional<std::uint64_t> domain,
            std::optional<flight::AttackLaw> attack, const fs::path& out, const sys::SignalFd& signals, bool tty) {
  const fs::path json = out / ("run_" + std::string(row.key) + ".json");
  const fs::path csv = out / ("run_" + std::string(row.key) + ".csv");
  const fs::path log = out / ("run_" + std::string(row.key) + ".log");
  std::error_code ec;
  fs::remove(json, ec);
  std::vector<std::string> args = {graph, "--seed", std::to_string(seed), "--summary-json", json.string(), "--csv",
                                   csv.string()};
  if (!row.sr) args.emplace_back("--no-sr");
  if (!row.attack) args.emplace_back("--no-attack");
  if (domain) args.insert(args.end(), {"--domain", std::to_string(*domain)});
  if (attack) args.insert(args.end(), {"--attack", std::string(flight::to_string(*attack))});
  auto child = start_rejuv_run(args, log);
  if (!child) return Mission{.problem = child.error()};

  const auto start = std::chrono::steady_clock::now();
  auto last_note = start;
  const auto every = tty ? std::chrono::seconds{2} : std::chrono::seconds{15};
  bool interrupted = false;
  while (true) {
    auto status = child->try_wait();
    if (!status) return Mission{.problem = "waiting for rejuv run: " + status.error().to_string()};
    if (*status) {
      // 0: completed safely; 1: a failed mission (e.g. no SR under attack) — a row of the table all the same.
      if (interrupted) return Mission{.problem = "interrupted", .interrupted = true};
      const auto s = read_summary(json);
      if (!s) {
        return Mission{.problem = "rejuv run " + (*status)->to_string() + " without a summary; see " + log.string()};
      }
      return Mission{.summary = *s};
    }
    if (auto sig = signals.read(); sig && *sig && !interrupted) {
      interrupted = true;  // let the mission stop cleanly (its kernel shuts every process down), then give up
      (void)child->signal(**sig);
    }
    if (std::chrono::steady_clock::now() - last_note >= every) {
      last_note = std::chrono::steady_clock::now();
      std::fprintf(stderr, "rejuv report:   %5.0f s wall  %s\n", seconds_since(start), last_progress(log).c_str());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds{100});
  }
}

std::string outcome_text(const proto::RunSummary& s) {
  std::string o = s.mission_completed() ? "completed" : "NOT COMPLETED";
  if (s.left_safety_set()) o += ", LEFT SAFETY SET";
  return o;
}

std::string table_text(const std::string& graph, std::uint64_t seed, const std::vector<proto::RunSummary>& run,
                       const std::vector<proto::RunSummary>& sim) {
  const std::string kind = sim.empty() ? std::string() : sim.back().attack_kind();
  std::string out = "Table I (" + graph + ", seed " + std::to_string(seed) + (kind.empty() ? "" : ", attack " + kind) +
                    "): runtime (rejuv run) | model (rejuv sim)\n";
  char line[512];
  std::snprintf(line, sizeof line, "%-17s | %-15s | %-19s | %-17s | %-15s | %s\n", "", "d_mean [cm]", "max V",
                "rollbacks/attacks", "mission time [s]", "outcome (runtime | model)");
  out += line;
  std::snprintf(line, sizeof line, "%-17s | %7s %7s | %9s %9s | %8s %8s | %7s %7s |\n", "configuration", "run",
                "sim", "run", "sim", "run", "sim", "run", "sim");
  out += line;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const proto::RunSummary& r = run[i];
    const proto::RunSummary& m = sim[i];
    const auto ra = std::to_string(r.rollbacks()) + "/" + std::to_string(r.attacks());
    const auto ma = std::to_string(m.rollbacks()) + "/" + std::to_string(m.attacks());
    std::snprintf(line, sizeof line, "%-17s | %7.2f %7.2f | %9.4f %9.4f | %8s %8s | %7.1f %7.1f | %s | %s\n",
                  kRows[i].label, 100.0 * r.d_mean_m(), 100.0 * m.d_mean_m(), r.max_v(), m.max_v(), ra.c_str(),
                  ma.c_str(), r.mission_time_s(), m.mission_time_s(), outcome_text(r).c_str(),
                  outcome_text(m).c_str());
    out += line;
  }
  return out;
}

// `rejuv report figures DIR`: the figures of an earlier `--out` run, from its files.
int report_figures(const fs::path& dir) {
  if (auto ok = check_run_dir(dir); !ok) return refuse("rejuv report figures: " + ok.error());
  const auto summary = read_summary(dir / RunFiles::kSummary);
  if (!summary || (summary->runner() != "run" && summary->runner() != "sim")) {
    return refuse("rejuv report figures: " + (dir / RunFiles::kSummary).string() +
                     ": error: not the RunSummary JSON of `rejuv run` or `rejuv sim`");
  }
  const auto drawn = draw_figures(dir, plots_dir(), figure_run_of(*summary));
  if (!drawn) {
    std::fprintf(stderr, "rejuv report figures: %s\n", drawn.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  for (const fs::path& p : drawn->written) std::printf("%s\n", p.c_str());
  for (const FigureFailure& f : drawn->failed) {
    std::fprintf(stderr, "rejuv report figures: figure %s not drawn: %s\n", f.figure.c_str(), f.why.c_str());
  }
  return static_cast<int>(drawn->failed.empty() ? Exit::Ok : Exit::Findings);
}

// What `rejuv report` was asked for.
struct ReportRequest {
  std::string what, graph_path;
  std::optional<std::uint64_t> seed_flag, domain;
  std::optional<std::filesystem::path> out_dir, reuse_path;
  std::optional<flight::AttackLaw> attack_law;
};

void declare_report_options(Options& opts, ReportRequest& r) {
  opts.positional("WHAT", r.what, "what to report: table or figures")
      .positional("GRAPH|DIR", r.graph_path, "table: the launch graph (*.launch.pbtxt); figures: a run's --out DIR");
  seed_option(opts, r.seed_flag, "seed of every run")
      .path("--out", "DIR", r.out_dir, "where the runs' files go", "out/table");
  domain_option(opts, r.domain, "DDS domain id of the runtime missions", "each mission leases a free one");
  attack_option(opts, r.attack_law)
      .path("--sr-attack-json", "FILE", r.reuse_path,
            "the runtime's 'SR, attack' row from this `rejuv run --summary-json` (same graph and seed) instead of\n"
            "flying it again (e.g. the demo's main mission)");
}

// --sr-attack-json's summary, checked to be `rejuv run` of this graph and seed with SR and attacks.
Result<std::optional<proto::RunSummary>, std::string> reused_row(const ReportRequest& r, const flight::SimConfig& config) {
  if (!r.reuse_path) return std::optional<proto::RunSummary>{};
  auto reused = read_summary(*r.reuse_path);
  if (!reused) return fail("--sr-attack-json: cannot read a run summary from '" + r.reuse_path->string() + "'");
  if (reused->runner() != "run" || !reused->sr() || !reused->attack() || reused->seed() != config.seed ||
      reused->graph() != config.graph_name || reused->attack_kind() != std::string(flight::to_string(config.attack.law))) {
    return fail("--sr-attack-json: '" + r.reuse_path->string() + "' is not `rejuv run` of " + config.graph_name +
                " with SR and attacks, seed " + std::to_string(config.seed));
  }
  return reused;
}

// Everything the rows of the table share.
struct TableJob {
  const ReportRequest& request;
  const flight::SimConfig& config;
  const std::optional<proto::RunSummary>& reused;
  fs::path out;
  const sys::SignalFd& signals;
  bool tty = false;
};

struct RowResult {
  proto::RunSummary run, sim;
};

// Row i: the model first (it takes a second), then the runtime, flown or --sr-attack-json's. The error is the
// exit code, its reason already on stderr.
Result<RowResult, int> fly_row(const TableJob& job, std::size_t i) {
  const Row& row = kRows[i];
  flight::SimConfig c = job.config;
  c.sr = row.sr ? flight::SrSwitch::On : flight::SrSwitch::Off;
  c.attack.enabled = row.attack ? flight::AttackSwitch::On : flight::AttackSwitch::Off;
  const auto model = flight::run_simulation(c);
  if (!model) return fail(refuse("rejuv report: " + model.error().to_string()));
  if (row.sr && row.attack && job.reused) {
    std::fprintf(stderr, "rejuv report: [%zu/4] %s: runtime row from %s\n", i + 1, row.label,
                 job.request.reuse_path->c_str());
    return RowResult{.run = *job.reused, .sim = *model};
  }
  std::fprintf(stderr, "rejuv report: [%zu/4] %s: rejuv run (log: %s)\n", i + 1, row.label,
               (job.out / ("run_" + std::string(row.key) + ".log")).c_str());
  const auto mission_start = std::chrono::steady_clock::now();
  Mission m = fly(row, job.request.graph_path, job.config.seed, job.request.domain, job.request.attack_law, job.out,
                  job.signals, job.tty);
  if (!m.summary) {
    std::fprintf(stderr, "rejuv report: %s: %s\n", row.label, m.problem.c_str());
    return fail(static_cast<int>(Exit::Findings));
  }
  std::fprintf(stderr, "rejuv report: [%zu/4] %s: %s, max V %.4f, %llu rollbacks, %.1f s flight in %.0f s wall\n", i + 1,
               row.label, outcome_text(*m.summary).c_str(), m.summary->max_v(),
               static_cast<unsigned long long>(m.summary->rollbacks()), m.summary->mission_time_s(),
               seconds_since(mission_start));
  return RowResult{.run = *m.summary, .sim = *model};
}

// `rejuv report table GRAPH`: the four rows, the table on stdout and in DIR/table.txt.
int report_table(const ReportRequest& r) {
  flight::SimOverrides overrides;
  overrides.seed = r.seed_flag;
  auto loaded = load_with_attack(r.graph_path, r.attack_law, "rejuv report");
  if (!loaded) return refuse(loaded.error());
  auto config = flight::config_from_launch(*loaded, overrides);
  if (!config) return refuse(config.error().to_string());
  const auto reused = reused_row(r, *config);
  if (!reused) return refuse("rejuv report: " + reused.error());
  const fs::path out = r.out_dir.value_or("out/table");
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) return refuse("rejuv report: --out: cannot create '" + out.string() + "': " + ec.message());
  // SIGINT/SIGTERM stop the mission in flight cleanly (forwarded to it), then the report.
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  if (!signals) {
    std::fprintf(stderr, "rejuv report: signalfd: %s\n", signals.error().to_string().c_str());
    return static_cast<int>(Exit::Findings);
  }
  const TableJob job{.request = r, .config = *config, .reused = *reused, .out = out, .signals = *signals,
                     .tty = isatty(STDERR_FILENO) == 1};
  std::vector<proto::RunSummary> run, sim;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < std::size(kRows); ++i) {
    const auto row = fly_row(job, i);
    if (!row) return row.error();
    run.push_back(row->run);
    sim.push_back(row->sim);
  }
  const std::string table = table_text(config->graph_name, config->seed, run, sim);
  std::fputs(table.c_str(), stdout);
  std::fprintf(stderr, "rejuv report: Table I in %.0f s wall; files in %s\n", seconds_since(start), out.c_str());
  if (UniqueFile f(std::fopen((out / "table.txt").c_str(), "w")); f) std::fputs(table.c_str(), f.get());
  return static_cast<int>(Exit::Ok);
}

}  // namespace

int run_report(std::span<const std::string_view> args) {
  ReportRequest r;
  Options opts("report",
               "Reports that compare the runtime with the model.\n"
               "  table GRAPH  Table I (§VI-D): SR on/off x attack on/off, each row a mission flown by the\n"
               "               multi-process runtime (`rejuv run`, lockstep) beside `rejuv sim` for the same seed:\n"
               "               d_mean, max V, rollbacks/attacks, mission time. The four runtime missions take a\n"
               "               few minutes; progress on stderr. Per row, --out gets run_<row>.json (summary),\n"
               "               .csv (trace) and .log (the run's output), and table.txt the table.\n"
               "  figures DIR  Figs. 7-10 and V/estimation error again (PNG and SVG, gnuplot) from the CSVs an\n"
               "               earlier `rejuv run ... --out DIR` or `rejuv sim ... --out DIR` wrote there.\n"
               "Exit 0 once every row ran (a row may be a failed mission: that is what Table I shows), 1 when a\n"
               "runtime mission could not be run, 2 on bad input.");
  declare_report_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.what == "figures") {
    if (r.seed_flag || r.out_dir || r.domain || r.reuse_path || r.attack_law) {
      return refuse("rejuv report figures: takes only DIR (--seed, --out, --domain, --attack, --sr-attack-json are "
                       "for table)");
    }
    return report_figures(r.graph_path);
  }
  if (r.what != "table") return refuse("rejuv report: unknown report '" + r.what + "' (expected: table or figures)");
  return report_table(r);
}

}  // namespace rejuv::cli
