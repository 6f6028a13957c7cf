// `rejuv sweep GRAPH --param PATH=VALUES [--param …]`: the design grid of §VI-D (Fig. 11: T_MC × T_est, 45
// consecutive worst-case attacks per cell, max ‖x − x_sp‖²_P and max ‖x − x̂‖²_P), for any launch parameter by
// field path, flown on the model (`sim`, in this process), the runtime (`run`, `rejuv run` children) or both;
// per cell and runner max V, max estimation error, d̄, max d, rollbacks, attacks and completion over the seeds;
// DIR/sweep.csv, DIR/sweep.json, DIR/fig11a.* and fig11b.* (gnuplot), resumable, shardable
// (`--shard i/n`, then `rejuv sweep merge DIR…`). docs/sweep.md. Exit 0 once every task of the sweep (or
// shard) has flown, 1 when a cell was refused, a mission failed to run or the sweep was interrupted, 2 on bad
// input.
#include <google/protobuf/text_format.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"
#include "sweep/execute.hpp"
#include "sweep/figures.hpp"
#include "sweep/grid.hpp"
#include "sweep/params.hpp"

namespace rejuv::cli {
namespace {

constexpr std::uint64_t kDefaultSeeds = 3;  // --seeds unset: the graph's seed and the next two

namespace fs = std::filesystem;
using sweep::Runner;
using sweep::Task;

std::string table(const proto::SweepReport& report) {
  std::string out;
  char line[512];
  for (const proto::SweepAxis& a : report.plan().axes()) {
    std::snprintf(line, sizeof line, "%-24s ", a.path().c_str());
    out += line;
  }
  std::snprintf(line, sizeof line, "%-6s %5s %17s %17s %8s %8s %9s %8s %9s %7s %9s\n", "runner", "seeds", "max V max/mean",
                "est.err max/mean", "d_mean", "d_max", "rollbacks", "attacks", "completed", "safe", "mission s");
  out += line;
  for (const proto::SweepCellResult& c : report.cells()) {
    for (const proto::SweepParamValue& p : c.params()) {
      std::snprintf(line, sizeof line, "%-24s ", p.value().c_str());
      out += line;
    }
    if (c.ok() == 0) {
      std::snprintf(line, sizeof line, "%-6s %5u  %s\n", c.runner().c_str(), c.seeds(), c.error().c_str());
    } else {
      std::snprintf(line, sizeof line,
                    "%-6s %2u/%-2u %8.3f/%-8.3f %8.3f/%-8.3f %5.1f cm %5.1f cm %9.1f %7.1f%s %6u/%-2u %4u/%-2u %9.1f%s\n",
                    c.runner().c_str(), c.ok(), c.seeds(), c.max_v().max(), c.max_v().mean(), c.max_est_err_p().max(),
                    c.max_est_err_p().mean(), 100 * c.d_mean_m().mean(), 100 * c.d_max_m().max(), c.rollbacks().mean(),
                    c.attacks().mean(), c.short_of_attacks() > 0 ? "*" : " ", c.completed(), c.ok(), c.safe(), c.ok(),
                    c.mission_time_s().mean(), c.safe() < c.ok() ? "  LEFT THE SAFETY SET" : "");
    }
    out += line;
  }
  const auto short_cells = std::count_if(report.cells().begin(), report.cells().end(),
                                         [](const proto::SweepCellResult& c) { return c.short_of_attacks() > 0; });
  if (short_cells > 0) {
    out += "*: " + std::to_string(short_cells) + " of " + std::to_string(report.cells_size()) +
           " cells had a mission that ended before " + std::to_string(report.plan().attacks()) +
           " attacks (sweep.csv short_of_attacks, attacks_min)\n";
  }
  const std::string charged = sweep::charges_text(report);
  if (!charged.empty()) {
    const std::string& how = report.plan().charges();
    out += "charged per checkpoint/rollback: " + charged +
           (how.empty() ? " (each runner its own: --charges paper|runtime flies both alike)" : " (--charges " + how + ")") + "\n";
  }
  return out;
}

// What a sweep's outputs say: records refused or failed, cells (of a runner) in which a seed left the safety set.
struct Outcome {
  std::size_t bad = 0;
  std::size_t unsafe = 0;
};

// sweep.csv, sweep.json and the figures of what `dir` holds.
Result<Outcome, std::string> write_outputs(const fs::path& dir, const proto::SweepPlan& plan) {
  const std::vector<proto::SweepRecord> records = sweep::kept_records(dir, plan);
  const proto::SweepReport report = sweep::aggregate(plan, records);
  if (auto w = sweep::write_atomically(dir / "sweep.csv", sweep::to_csv(report)); !w) return fail(w.error());
  if (auto w = sweep::write_atomically(dir / "sweep.json", sweep::to_json_text(report) + "\n"); !w) return fail(w.error());
  std::fputs(table(report).c_str(), stdout);
  std::printf("rejuv sweep: %s/sweep.csv, %s/sweep.json", dir.c_str(), dir.c_str());
  if (report.missing() > 0) std::printf(" (%u planned records missing)", report.missing());
  std::printf("\n");
  if (report.cells_size() > 0) {
    const auto figures = sweep::draw_figures(dir, report, fs::path(REJUV_SOURCE_DIR) / "tools" / "plots" / "sweep.gp");
    if (!figures) {
      std::fprintf(stderr, "rejuv sweep: no figures: %s\n", figures.error().c_str());
    } else {
      std::string names;
      for (const fs::path& p : *figures) names += (names.empty() ? "" : ", ") + p.filename().string();
      std::printf("rejuv sweep: figures %s in %s\n", names.c_str(), dir.c_str());
    }
  }
  return Outcome{
      .bad = static_cast<std::size_t>(std::count_if(records.begin(), records.end(),
                                                    [](const proto::SweepRecord& r) { return r.status() != "ok"; })),
      .unsafe = static_cast<std::size_t>(std::count_if(report.cells().begin(), report.cells().end(),
                                                       [](const proto::SweepCellResult& c) { return c.safe() < c.ok(); }))};
}

// Exit 1 for a cell that left the safety set, unless that is what the user studies (--allow-unsafe): a sweep
// that "completed" cells outside the safety set must not look like a success.
bool unsafe_is_finding(const Outcome& o, bool allow_unsafe, const char* who) {
  if (o.unsafe == 0) return false;
  std::fprintf(stderr, "%s: %zu cell%s LEFT THE SAFETY SET (max V >= 1 for a seed: the table's last column)%s\n", who,
               o.unsafe, o.unsafe == 1 ? "" : "s",
               allow_unsafe ? "" : "; exit 1 (--allow-unsafe when leaving it is what the sweep studies)");
  return !allow_unsafe;
}

int run_merge(std::span<const std::string_view> args) {
  std::vector<std::string> dirs;
  std::optional<fs::path> out_dir;
  bool allow_unsafe = false;
  Options opts("sweep merge",
               "Combine the folders of a sharded sweep (`rejuv sweep … --shard i/n --out DIR_i`, docs/sweep.md):\n"
               "their plans must be the same sweep; the records of all go to --out (default: the first DIR),\n"
               "which then gets sweep.csv, sweep.json and the figures. Exit 0 when the merged sweep is complete,\n"
               "1 when records are missing, a cell was refused or failed or left the safety set (unless --allow-unsafe),\n"
               "2 on bad input.");
  opts.positionals("DIR", dirs, "sweep folders (one per shard)")
      .path("--out", "DIR", out_dir, "where the merged sweep goes", "the first DIR")
      .flag("--allow-unsafe", allow_unsafe, "exit 0 even when a cell left the safety set");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  auto plan = sweep::read_plan(dirs.front());
  if (!plan) return refuse("rejuv sweep merge: " + plan.error());
  for (const std::string& d : dirs) {
    auto other = sweep::read_plan(d);
    if (!other) return refuse("rejuv sweep merge: " + other.error());
    if (!sweep::same_plan(*plan, *other)) {
      return refuse("rejuv sweep merge: " + d + " holds another sweep than " + dirs.front() +
                       " (graph, parameters, seeds, attacks or runners differ: compare their plan.json)");
    }
  }
  const fs::path out = out_dir.value_or(fs::path(dirs.front()));
  std::error_code ec;
  fs::create_directories(out / "cells", ec);
  if (ec) return refuse("rejuv sweep merge: --out: cannot create '" + out.string() + "': " + ec.message());
  if (auto w = sweep::write_plan(out, *plan); !w) return refuse("rejuv sweep merge: " + w.error());
  std::size_t copied = 0;
  for (const std::string& d : dirs) {
    if (fs::equivalent(d, out, ec)) continue;
    for (const proto::SweepRecord& r : sweep::kept_records(d, *plan)) {
      if (auto w = sweep::write_record(out, r); !w) return refuse("rejuv sweep merge: " + w.error());
      ++copied;
    }
  }
  std::fprintf(stderr, "rejuv sweep merge: %zu records from %zu folders into %s\n", copied, dirs.size(), out.c_str());
  const auto bad = write_outputs(out, *plan);
  if (!bad) return refuse("rejuv sweep merge: " + bad.error());
  const proto::SweepReport report = sweep::aggregate(*plan, sweep::kept_records(out, *plan));
  const bool unsafe = unsafe_is_finding(*bad, allow_unsafe, "rejuv sweep merge");
  return static_cast<int>(bad->bad == 0 && report.missing() == 0 && !unsafe ? Exit::Ok : Exit::Findings);
}

}  // namespace

// Each cell's launch written to DIR/launch/cell-NNNN.launch.pbtxt and checked by the loader of `rejuv run` and
// `rejuv sim` (and the model's control design): a refused cell carries why, and is recorded, not flown.
Result<std::vector<sweep::CellLaunch>, std::string> write_cell_launches(const fs::path& dir, const proto::Launch& graph,
                                                                       const proto::SweepPlan& plan) {
  const fs::path base_dir = fs::path(plan.graph()).parent_path();
  std::vector<sweep::CellLaunch> cells;
  std::error_code ec;
  for (std::uint32_t c = 0; c < sweep::cell_count(plan); ++c) {
    char name[64];
    std::snprintf(name, sizeof name, "cell-%04u.launch.pbtxt", c);
    sweep::CellLaunch cell{.file = fs::absolute(dir / "launch" / name, ec), .text = {}, .refused = {}};
    auto launch = sweep::cell_launch(graph, base_dir, plan, c);
    if (!launch) return fail(launch.error());
    google::protobuf::TextFormat::PrintToString(*launch, &cell.text);
    cell.text = "# rejuv sweep: cell " + std::to_string(c) + " of " + plan.graph() + "\n" + cell.text;
    if (auto w = sweep::write_atomically(cell.file, cell.text); !w) return fail(w.error());
    auto parsed_cell = launch::parse_launch(cell.text, cell.file);
    if (!parsed_cell) {
      cell.refused = parsed_cell.error().to_string();
    } else if (auto config = flight::config_from_launch(*parsed_cell, {}); !config) {
      cell.refused = config.error().to_string();
    }
    cells.push_back(std::move(cell));
  }
  return cells;
}

namespace {

enum class Runners : std::uint8_t { Sim, Run, Both };
enum class Charges : std::uint8_t { Own, Paper, Runtime };

// What `rejuv sweep` was asked for.
struct SweepRequest {
  std::string graph_path;
  std::vector<std::string> params;
  std::optional<std::vector<std::uint64_t>> seeds;
  std::optional<sweep::Shard> shard;
  std::uint64_t attacks = 45, jobs = 1;
  Runners runner = Runners::Sim;
  fs::path dir = "out/sweep";
  bool resume = false;
  bool allow_unsafe = false;
  Charges charges = Charges::Own;
};

void declare_sweep_options(Options& opts, SweepRequest& r) {
  opts.positional("GRAPH", r.graph_path, "the launch graph (*.launch.pbtxt) the sweep varies")
      .repeated("--param", "PATH=VALUES", r.params,
                "a launch field by path and its values: a:b:step (inclusive), v1,v2,... or one value;\n"
                "e.g. sr.t_mc_s=0.2:0.3:0.025, sr.restricted_limit_fraction=0.1,0.2,\n"
                "attack.attacks[0].kind=WORST_CASE_CONTROL (one or two --param)")
      .required()
      .custom<std::vector<std::uint64_t>>("--seeds", "LIST", r.seeds, sweep::parse_seeds,
                                          "seeds of each cell: a-b, a,b,c or one", "the graph's seed and the next two")
      .integer("--attacks", "N", r.attacks, {0, 100000}, "end each mission after N attacked MC windows (0 = fly it)")
      .choice<Runners>("--runner", {{"sim", Runners::Sim}, {"run", Runners::Run}, {"both", Runners::Both}}, r.runner,
                       "the model, the runtime or both")
      .integer("--jobs", "N", r.jobs, {1, 256}, "cells flown in parallel")
      .path("--out", "DIR", r.dir, "output folder")
      .flag("--resume", r.resume, "continue the sweep kept in DIR: fly only the tasks without a record")
      .flag("--allow-unsafe", r.allow_unsafe, "exit 0 even when a cell left the safety set (studying the boundary)")
      .choice<Charges>("--charges", {{"paper", Charges::Paper}, {"runtime", Charges::Runtime}}, r.charges,
                       "charge both runners alike per checkpoint/rollback: the paper's 20/15 ms (§VI-B) or the\n"
                       "launch file's lockstep charges; unset: the model the paper's, the runtime its own\n"
                       "(sweep.csv and the figures say which)")
      .custom<sweep::Shard>("--shard", "i/n", r.shard, sweep::parse_shard,
                            "fly only every n-th cell, from the i-th (1-based); see `merge`");
}

// The sweep's plan (DIR/plan.json): the graph, its axes, seeds, attacks, charges and runners.
Result<proto::SweepPlan, std::string> plan_sweep(const SweepRequest& r, const proto::Launch& graph) {
  proto::SweepPlan plan;
  std::error_code ec;
  plan.set_graph(fs::absolute(r.graph_path, ec).lexically_normal().string());
  std::set<std::string> paths;
  for (const std::string& p : r.params) {
    auto axis = sweep::make_axis(graph, p);
    if (!axis) return fail(axis.error());
    if (!paths.insert(axis->path()).second) return fail("--param " + axis->path() + " given twice");
    *plan.add_axes() = *axis;
  }
  if (r.seeds) {
    for (const std::uint64_t s : *r.seeds) plan.add_seeds(s);
  } else {
    // One seed is one sample of the sensor noise and the wind: a cell's max V over three is the least a figure
    // should rest on (docs/sweep.md).
    for (std::uint64_t k = 0; k < kDefaultSeeds; ++k) plan.add_seeds(graph.seed() + k);
  }
  plan.set_attacks(static_cast<std::uint32_t>(r.attacks));
  if (r.charges == Charges::Paper) plan.set_charges(std::string(sweep::kChargesPaper));
  if (r.charges == Charges::Runtime) plan.set_charges(std::string(sweep::kChargesRuntime));
  if (r.runner != Runners::Run) plan.add_runners("sim");
  if (r.runner != Runners::Sim) plan.add_runners("run");
  if (sweep::cell_count(plan) > 100000) return fail(std::string("more than 100000 cells"));
  return plan;
}

// The folder: a new sweep, or (--resume) the same sweep continued; its plan written.
Result<void, std::string> prepare_folder(const SweepRequest& r, const proto::SweepPlan& plan) {
  std::error_code ec;
  if (fs::exists(r.dir / "plan.json", ec)) {
    if (!r.resume) return fail(r.dir.string() + " holds a sweep already: --resume to continue it, or another --out");
    const auto kept = sweep::read_plan(r.dir);
    if (!kept) return fail(kept.error());
    if (!sweep::same_plan(*kept, plan)) {
      return fail("--resume: " + r.dir.string() + " holds another sweep (its plan.json differs in graph, "
                  "parameters, seeds, attacks, runners or charges)");
    }
  }
  fs::create_directories(r.dir / "cells", ec);
  if (!ec) fs::create_directories(r.dir / "launch", ec);
  if (ec) return fail("--out: cannot create '" + r.dir.string() + "': " + ec.message());
  return sweep::write_plan(r.dir, plan);
}

// The tasks of this sweep (or shard) still to fly, and how many --resume found kept.
struct Todo {
  std::vector<Task> tasks;
  std::size_t kept = 0;
};
Todo tasks_to_fly(const SweepRequest& r, const proto::SweepPlan& plan) {
  Todo todo;
  for (const Task& t : sweep::tasks_of(plan, r.shard.value_or(sweep::Shard{}))) {
    if (r.resume && sweep::kept_record(r.dir, plan, t)) {
      ++todo.kept;
    } else {
      todo.tasks.push_back(t);
    }
  }
  return todo;
}

void announce(const SweepRequest& r, const proto::SweepPlan& plan, const Todo& todo,
              const std::vector<sweep::CellLaunch>& cells) {
  const auto refused = static_cast<std::size_t>(
      std::count_if(cells.begin(), cells.end(), [](const sweep::CellLaunch& c) { return !c.refused.empty(); }));
  std::fprintf(stderr, "rejuv sweep: %u cells x %d seeds x %d runners%s: %zu tasks to fly, %zu kept, %llu jobs%s\n",
               sweep::cell_count(plan), plan.seeds_size(), plan.runners_size(),
               r.shard ? (" (shard " + std::to_string(r.shard->index + 1) + "/" + std::to_string(r.shard->count) + ")").c_str() : "",
               todo.tasks.size(), todo.kept, static_cast<unsigned long long>(r.jobs),
               refused > 0 ? (", " + std::to_string(refused) + " cells refused by the launch loader").c_str() : "");
}

// The outputs of what DIR holds and the exit code: 1 when interrupted, a task refused or failed, or a cell
// left the safety set (unless --allow-unsafe).
int finish_sweep(const SweepRequest& r, const proto::SweepPlan& plan, sweep::ExecOutcome outcome) {
  const auto bad = write_outputs(r.dir, plan);
  if (!bad) {
    std::fprintf(stderr, "rejuv sweep: %s\n", bad.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  if (outcome == sweep::ExecOutcome::Interrupted) {
    std::fprintf(stderr, "rejuv sweep: interrupted; the finished missions are kept in %s/cells: "
                 "add --resume to continue\n", r.dir.c_str());
    return static_cast<int>(Exit::Findings);
  }
  if (bad->bad > 0) {
    std::fprintf(stderr, "rejuv sweep: %zu tasks refused or failed (sweep.csv, column error)\n", bad->bad);
    return static_cast<int>(Exit::Findings);
  }
  if (unsafe_is_finding(*bad, r.allow_unsafe, "rejuv sweep")) return static_cast<int>(Exit::Findings);
  return static_cast<int>(Exit::Ok);
}

}  // namespace

int run_sweep(std::span<const std::string_view> args) {
  if (!args.empty() && args.front() == "merge") return run_merge(args.subspan(1));
  SweepRequest r;
  Options opts("sweep",
      "Fly a grid of launch parameters (§VI-D, Fig. 11: T_MC x T_est with 45 consecutive worst-case attacks per\n"
      "cell) on the model (`sim`: in this process, --jobs threads), the runtime (`run`: one `rejuv run` per cell\n"
      "and seed, --jobs at a time, each on its own CPU, DDS domain and port) or both. Each cell flies until\n"
      "--attacks MC windows were attacked (launch field stop_after_attacks) or the mission ends. Writes\n"
      "DIR/sweep.csv, DIR/sweep.json (per cell: params, per seed and max/mean over the seeds of max V, max\n"
      "estimation error, d_mean, d_max, rollbacks, attacks, completion), DIR/fig11a.{png,svg} (max V, the\n"
      "V = 1 boundary drawn) and DIR/fig11b.{png,svg} (max estimation error), model and runtime side by side.\n"
      "Every finished mission is kept in DIR/cells: --resume continues an interrupted sweep. `rejuv sweep merge\n"
      "DIR...` combines the folders of --shard i/n runs (docs/sweep.md). Exit 0 once every task flew inside the\n"
      "safety set, 1 when a cell left it (unless --allow-unsafe), was refused, a mission failed to run or the\n"
      "sweep was interrupted, 2 on bad input.");
  declare_sweep_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.params.empty() || r.params.size() > 2) {
    return refuse("rejuv sweep: expected one or two --param PATH=VALUES, got " + std::to_string(r.params.size()));
  }
  auto loaded = launch::load_launch(r.graph_path);
  if (!loaded) return refuse(loaded.error().to_string());
  const auto plan = plan_sweep(r, loaded->graph);
  if (!plan) return refuse("rejuv sweep: " + plan.error());
  if (auto ready = prepare_folder(r, *plan); !ready) return refuse("rejuv sweep: " + ready.error());
  auto cells = write_cell_launches(r.dir, loaded->graph, *plan);
  if (!cells) return refuse("rejuv sweep: " + cells.error());
  const Todo todo = tasks_to_fly(r, *plan);
  announce(r, *plan, todo, *cells);
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  if (!signals) return refuse("rejuv sweep: signalfd: " + signals.error().to_string());
  const auto outcome = sweep::execute(*plan, *cells, todo.tasks, todo.kept,
                                      sweep::ExecConfig{.dir = r.dir,
                                                        .jobs = static_cast<unsigned>(r.jobs),
                                                        .tty = isatty(STDERR_FILENO) == 1,
                                                        .signals = &*signals});
  if (!outcome) {
    std::fprintf(stderr, "rejuv sweep: %s\n", outcome.error().c_str());
    return static_cast<int>(Exit::Findings);
  }
  return finish_sweep(r, *plan, *outcome);
}

}  // namespace rejuv::cli
