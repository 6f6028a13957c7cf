#include "sweep/execute.hpp"


#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/launch/launch.hpp"
#include "job_pool.hpp"
#include "rejuv/sys/lease.hpp"
#include "run_child.hpp"

namespace rejuv::cli::sweep {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

proto::SweepRecord new_record(const proto::SweepPlan& plan, const Task& task) {
  proto::SweepRecord r;
  r.set_cell(task.cell);
  for (const proto::SweepParamValue& p : cell_params(plan, task.cell)) *r.add_params() = p;
  r.set_seed(task.seed);
  r.set_runner(std::string(to_string(task.runner)));
  r.set_attacks(plan.attacks());
  return r;
}

std::string describe(const Task& task, const proto::SweepRecord& r) {
  std::string params;
  for (const proto::SweepParamValue& p : r.params()) params += (params.empty() ? "" : " ") + p.path() + "=" + p.value();
  char buf[512];
  if (r.status() == "ok") {
    std::snprintf(buf, sizeof buf, "%s cell %u [%s] seed %llu: max V %.3f, est. err %.3f, %llu attacks%s",
                  std::string(to_string(task.runner)).c_str(), task.cell, params.c_str(),
                  static_cast<unsigned long long>(task.seed), r.summary().max_v(), r.summary().max_est_err_p(),
                  static_cast<unsigned long long>(r.summary().attacks()),
                  r.summary().mission_completed() || r.summary().stopped_after_attacks() ? "" : ", NOT COMPLETED");
  } else {
    std::snprintf(buf, sizeof buf, "%s cell %u [%s] seed %llu: %s", std::string(to_string(task.runner)).c_str(),
                  task.cell, params.c_str(), static_cast<unsigned long long>(task.seed), r.status().c_str());
  }
  return buf;
}

std::string clock_text(double s) {
  char buf[32];
  const auto t = static_cast<long long>(s + 0.5);
  if (t >= 3600) {
    std::snprintf(buf, sizeof buf, "%lldh%02lldm", t / 3600, (t / 60) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%lldm%02llds", t / 60, t % 60);
  }
  return buf;
}

// Progress on stderr: a bar redrawn in place on a terminal, one line per finished task otherwise. ETA from
// each runner's mean wall time per task so far, divided among the jobs.
class Progress {
 public:
  Progress(const std::vector<Task>& todo, std::size_t kept, unsigned jobs, bool tty)
      : total_(todo.size() + kept), done_(kept), jobs_(jobs), tty_(tty) {
    for (const Task& t : todo) ++left_[index(t.runner)];
  }

  void finished(const Task& task, double wall_s, const proto::SweepRecord& r) {
    ++done_;
    --left_[index(task.runner)];
    ++count_[index(task.runner)];
    wall_[index(task.runner)] += wall_s;
    last_ = describe(task, r);
    if (!tty_) {
      std::fprintf(stderr, "rejuv sweep: %zu/%zu (%3.0f%%) %s  ETA %s\n", done_, total_,
                   100.0 * static_cast<double>(done_) / static_cast<double>(total_), last_.c_str(), eta().c_str());
    }
    draw();
  }

  // Redraws the bar (terminal only).
  void draw() {
    if (!tty_) return;
    constexpr int kWidth = 30;
    const int filled = total_ == 0 ? kWidth : static_cast<int>(kWidth * done_ / total_);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(stderr, "\r\033[K[%s] %zu/%zu  ETA %s  %s", bar.c_str(), done_, total_, eta().c_str(),
                 last_.substr(0, 80).c_str());
  }

  void end() {
    if (tty_) std::fputc('\n', stderr);
  }

 private:
  static std::size_t index(Runner r) { return r == Runner::Sim ? 0 : 1; }
  [[nodiscard]] std::string eta() const {
    double s = 0;
    bool unknown = false;
    for (std::size_t i = 0; i < 2; ++i) {
      if (left_[i] == 0) continue;
      if (count_[i] == 0) {
        unknown = true;
        continue;
      }
      s += static_cast<double>(left_[i]) * wall_[i] / static_cast<double>(count_[i]) / static_cast<double>(jobs_);
    }
    if (unknown && s == 0) return "?";
    return clock_text(s) + (unknown ? "+?" : "");
  }

  std::size_t total_, done_;
  unsigned jobs_;
  bool tty_;
  std::size_t left_[2] = {0, 0}, count_[2] = {0, 0};
  double wall_[2] = {0, 0};
  std::string last_;
};

bool interrupted_by(const sys::SignalFd* signals) {
  if (signals == nullptr) return false;
  auto sig = signals->read();
  return sig && *sig;
}

// The model: one task, in this thread. nullopt when `stop` was raised meanwhile.
std::optional<proto::SweepRecord> fly_model(const proto::SweepPlan& plan, const CellLaunch& cell, const Task& task,
                                            const std::atomic<bool>& stop) {
  proto::SweepRecord r = new_record(plan, task);
  if (!cell.refused.empty()) {
    r.set_status("invalid");
    r.set_error(cell.refused);
    return r;
  }
  auto loaded = launch::parse_launch(cell.text, cell.file);
  if (!loaded) {
    r.set_status("invalid");
    r.set_error(loaded.error().to_string());
    return r;
  }
  flight::SimOverrides overrides{.seed = task.seed};
  if (plan.charges() == kChargesRuntime) {  // the model charges what the runtime does
    overrides.t_cp = launch::checkpoint_charge(loaded->graph.lockstep());
    overrides.t_rb = launch::rollback_charge(loaded->graph.lockstep());
  }
  auto config = flight::config_from_launch(*loaded, overrides);
  if (!config) {
    r.set_status("invalid");
    r.set_error(config.error().to_string());
    return r;
  }
  auto sim = flight::SrSimulation::create(*config);
  if (!sim) {
    r.set_status("failed");
    r.set_error(sim.error().to_string());
    return r;
  }
  for (std::uint64_t n = 1; sim->step(); ++n) {
    if (n % 4096 == 0 && stop.load(std::memory_order_relaxed)) return std::nullopt;
  }
  r.set_status("ok");
  *r.mutable_summary() = sim->summary();
  return r;
}

Result<ExecOutcome, std::string> fly_models(const proto::SweepPlan& plan, const std::vector<CellLaunch>& cells,
                                            const std::vector<Task>& tasks, const ExecConfig& config,
                                            Progress& progress) {
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::mutex mutex;  // guards the queue below
  struct Finished {
    Task task;
    double wall_s;
    proto::SweepRecord record;
  };
  std::vector<Finished> finished;
  std::string write_error;
  const auto worker = [&] {
    while (!stop.load()) {
      const std::size_t i = next.fetch_add(1);
      if (i >= tasks.size()) return;
      const auto start = Clock::now();
      auto r = fly_model(plan, cells[tasks[i].cell], tasks[i], stop);
      if (!r) return;
      const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
      const auto written = write_record(config.dir, *r);
      const std::lock_guard lock(mutex);
      if (!written) write_error = written.error();
      finished.push_back(Finished{tasks[i], wall_s, std::move(*r)});
    }
  };
  std::vector<std::thread> threads;
  const unsigned n = std::max(1U, std::min<unsigned>(config.jobs, static_cast<unsigned>(tasks.size())));
  for (unsigned t = 0; t < n; ++t) threads.emplace_back(worker);
  bool interrupted = false;
  std::size_t reported = 0;
  while (reported < tasks.size() && !interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds{50});
    if (interrupted_by(config.signals)) {
      interrupted = true;
      stop.store(true);
    }
    std::vector<Finished> now;
    {
      const std::lock_guard lock(mutex);
      now.swap(finished);
      if (!write_error.empty()) stop.store(true);
    }
    for (const Finished& f : now) progress.finished(f.task, f.wall_s, f.record);
    reported += now.size();
    if (stop.load() && !interrupted) break;
  }
  for (std::thread& t : threads) t.join();
  if (!write_error.empty()) return fail("cannot keep a record: " + write_error);
  return interrupted ? ExecOutcome::Interrupted : ExecOutcome::Done;
}

// Where a `rejuv run` mission's summary and log go: DIR/logs/<the record's name>.{summary.json,log}.
struct MissionFiles {
  fs::path summary, log;
};
MissionFiles files_of(const fs::path& dir, const Task& task) {
  const std::string stem = record_path(dir, task).stem().string();
  return {.summary = dir / "logs" / (stem + ".summary.json"), .log = dir / "logs" / (stem + ".log")};
}

proto::SweepRecord landed(const proto::SweepPlan& plan, const Task& task, const MissionFiles& files,
                          const sys::ExitStatus& status) {
  proto::SweepRecord r = new_record(plan, task);
  if (const auto s = read_summary(files.summary)) {
    r.set_status("ok");  // exit 1 with a summary is a mission that failed: a result all the same
    *r.mutable_summary() = *s;
    return r;
  }
  const bool refused = status.how == sys::ExitStatus::How::Exited && status.value == 2;
  r.set_status(refused ? "invalid" : "failed");
  r.set_error("rejuv run " + status.to_string() + " without a summary (" + files.log.string() + "): " +
              log_tail(files.log, 3));
  return r;
}

// Records the tasks whose cell the launch loader (the same as `rejuv run`'s) refused: no mission to fly.
// Returns the others.
Result<std::vector<Task>, std::string> record_refused(const proto::SweepPlan& plan, const std::vector<CellLaunch>& cells,
                                                      const std::vector<Task>& tasks, const ExecConfig& config,
                                                      Progress& progress) {
  std::vector<Task> flyable;
  for (const Task& task : tasks) {
    const CellLaunch& cell = cells[task.cell];
    if (cell.refused.empty()) {
      flyable.push_back(task);
      continue;
    }
    proto::SweepRecord r = new_record(plan, task);
    r.set_status("invalid");
    r.set_error(cell.refused);
    if (auto w = write_record(config.dir, r); !w) return fail("cannot keep a record: " + w.error());
    progress.finished(task, 0.0, r);
  }
  return flyable;
}

// The runtime: one `rejuv run` per task in the job pool's slots (each its own DDS domain and CPU). The
// mission is spawned, not forked, so that it is exactly what a user gets from `rejuv run` (run_child.hpp: its
// own process group; Ctrl-C reaches this process, whose pool stops each mission cleanly and keeps no record).
Result<ExecOutcome, std::string> fly_runtime(const proto::SweepPlan& plan, const std::vector<CellLaunch>& cells,
                                             const std::vector<Task>& tasks, const ExecConfig& config,
                                             Progress& progress) {
  const auto flyable = record_refused(plan, cells, tasks, config, progress);
  if (!flyable) return fail(flyable.error());
  if (flyable->empty()) return ExecOutcome::Done;
  auto pool = JobPool::create(
      PoolConfig{.workers = std::min<unsigned>(config.jobs, static_cast<unsigned>(flyable->size())), .signals = config.signals});
  if (!pool) return fail("no free DDS domain (" + std::string(sys::kDdsDomainLockFile) + "): " + pool.error());
  std::error_code ec;
  fs::create_directories(config.dir / "logs", ec);
  if (ec) return fail("cannot create " + (config.dir / "logs").string() + ": " + ec.message());
  const auto start = [&](std::size_t i, const WorkerSlot& slot) {
    const Task& task = (*flyable)[i];
    const MissionFiles files = files_of(config.dir, task);
    std::error_code ignored;
    fs::remove(files.summary, ignored);
    return start_rejuv_run({cells[task.cell].file.string(), "--seed", std::to_string(task.seed), "--domain",
                            std::to_string(slot.dds_domain), "--net-port", "0", "--cpu", std::to_string(slot.cpu),
                            "--summary-json", files.summary.string()},
                           files.log);
  };
  const auto ended = [&](const TaskEnd& end) -> Result<void, std::string> {
    const Task& task = (*flyable)[end.task];
    const proto::SweepRecord r = landed(plan, task, files_of(config.dir, task), end.status);
    if (auto w = write_record(config.dir, r); !w) return fail("cannot keep a record: " + w.error());
    progress.finished(task, end.wall.count(), r);
    return {};
  };
  const auto outcome = pool->run(flyable->size(), start, PoolHooks{.ended = ended, .tick = [&] { progress.draw(); }});
  if (!outcome) return fail(outcome.error());
  return *outcome == PoolOutcome::Interrupted ? ExecOutcome::Interrupted : ExecOutcome::Done;
}

}  // namespace

Result<ExecOutcome, std::string> execute(const proto::SweepPlan& plan, const std::vector<CellLaunch>& cells,
                                         const std::vector<Task>& todo, std::size_t kept, const ExecConfig& config) {
  Progress progress(todo, kept, config.jobs, config.tty);
  std::vector<Task> models, missions;
  for (const Task& t : todo) (t.runner == Runner::Sim ? models : missions).push_back(t);
  auto outcome = models.empty() ? Result<ExecOutcome, std::string>(ExecOutcome::Done)
                                : fly_models(plan, cells, models, config, progress);
  if (outcome && *outcome == ExecOutcome::Done && !missions.empty()) {
    outcome = fly_runtime(plan, cells, missions, config, progress);
  }
  progress.end();
  return outcome;
}

}  // namespace rejuv::cli::sweep
