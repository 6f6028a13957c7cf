// The fault campaign's missions (fault_campaign.hpp): the injector (an Observer that forwards everything to
// `rejuv run`'s recorder and carries out the faults, at lockstep steps or exactly at the kernel's ImagePhase
// boundaries), the mission-level checks (leaks, the wall-clock watchdog) and a job's loop over its missions.
// The plan and the outcome's encoding are in fault_plan.cpp.
#include "fault_campaign.hpp"

#include <dirent.h>
#include <pthread.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "common_options.hpp"
#include "rejuv/core/result.hpp"
#include "run_recorder.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/sanitizer.hpp"

#ifndef REJUV_SOURCE_DIR
#define REJUV_SOURCE_DIR ""
#endif

namespace rejuv::cli::faults {

namespace {

// ---- the process's own resources (the leak check) ----

std::size_t count_fds() {
  std::size_t n = 0;
  if (DIR* d = ::opendir("/proc/self/fd"); d != nullptr) {
    while (const dirent* e = ::readdir(d)) {
      if (e->d_name[0] != '.') ++n;
    }
    ::closedir(d);
    --n;  // the directory's own
  }
  return n;
}

std::vector<int> children() {
  std::vector<int> out;
  const int self = ::getpid();
  if (DIR* d = ::opendir("/proc"); d != nullptr) {
    while (const dirent* e = ::readdir(d)) {
      if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
      std::ifstream stat(std::string("/proc/") + e->d_name + "/stat");
      std::string text;
      std::getline(stat, text);  // one line (istreambuf_iterator trips g++ 12's -Wnull-dereference at -O2)
      const auto paren = text.rfind(')');
      if (paren == std::string::npos) continue;
      std::istringstream rest(text.substr(paren + 1));
      char state = 0;
      int ppid = 0;
      rest >> state >> ppid;
      if (ppid == self) out.push_back(std::atoi(e->d_name));
    }
    ::closedir(d);
  }
  return out;
}

// The memory this process holds [kB]: its RSS, or in a sanitizer build its allocator's bytes in use (ASan's
// quarantine and either sanitizer's shadow grow the RSS with every page touched: rejuv/sys/sanitizer.hpp).
constexpr const char* kMemoryName = sys::kSanitizerBuild ? "heap" : "RSS";
long memory_kb() {
  if (sys::kSanitizerBuild) return static_cast<long>(sys::heap_in_use_bytes() / 1024U);
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return 0;
}

// ---- the helper thread: SIGCONT after a stall, and the mission's watchdog ----

class Helper {
 public:
  Helper() : thread_([this] { loop(); }) {}
  Helper(const Helper&) = delete;
  Helper& operator=(const Helper&) = delete;
  ~Helper() {
    stop_ = true;
    thread_.join();
  }
  void cont_after(int pid, Nanos wall_delay) {
    const std::lock_guard lock(mu_);
    conts_.emplace_back(pid, sys_now() + wall_delay);
  }
  void clear_conts() {
    const std::lock_guard lock(mu_);
    conts_.clear();
  }
  void arm_watchdog(Nanos bound) {
    const std::lock_guard lock(mu_);
    watchdog_ = sys_now() + bound;
    expired_ = false;
  }
  void disarm_watchdog() {
    const std::lock_guard lock(mu_);
    watchdog_.reset();
  }
  [[nodiscard]] bool expired() {
    const std::lock_guard lock(mu_);
    return expired_;
  }

 private:
  static Nanos sys_now() { return std::chrono::duration_cast<Nanos>(std::chrono::steady_clock::now().time_since_epoch()); }
  void loop() {
    // Every signal blocked here: the kernel's SIGTERM (the watchdog) goes to its signalfd.
    sigset_t all;
    sigfillset(&all);
    ::pthread_sigmask(SIG_BLOCK, &all, nullptr);
    while (!stop_) {
      std::this_thread::sleep_for(std::chrono::milliseconds{20});
      const std::lock_guard lock(mu_);
      const Nanos now = sys_now();
      std::erase_if(conts_, [&](const std::pair<int, Nanos>& c) {
        if (c.second > now) return false;
        ::kill(c.first, SIGCONT);
        return true;
      });
      if (watchdog_ && now > *watchdog_) {
        if (!expired_) {
          expired_ = true;
          ::kill(::getpid(), SIGTERM);  // the kernel stops (StopReason::Signal) and shuts everything down
          watchdog_ = now + std::chrono::seconds{60};
        } else {
          std::fprintf(stderr, "rejuv faults: a mission did not stop 60 s after SIGTERM: the job gives up\n");
          std::_Exit(3);
        }
      }
    }
  }
  std::mutex mu_;
  std::vector<std::pair<int, Nanos>> conts_;
  std::optional<Nanos> watchdog_;
  bool expired_ = false;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct Counters {
  std::uint64_t rollbacks = 0, timer_rollbacks = 0, fallbacks = 0, cold_restarts = 0, checkpoint_failures = 0;
  static Counters of(const kernel::SrStats& s) {
    return {s.rollbacks, s.timer_rollbacks, s.fallbacks, s.cold_restarts, s.checkpoint_failures};
  }
};

std::string recovery_path(const Counters& a, const Counters& b) {
  if (b.cold_restarts > a.cold_restarts) return "cold restart";
  if (b.fallbacks > a.fallbacks) return "fallback to an earlier generation";
  const bool fault_rollback = (b.rollbacks - a.rollbacks) > (b.timer_rollbacks - a.timer_rollbacks);
  if (b.checkpoint_failures > a.checkpoint_failures) {
    return fault_rollback ? "checkpoint abandoned, rollback" : "checkpoint abandoned, timer rollback";
  }
  if (fault_rollback) return "rollback";
  if (b.rollbacks > a.rollbacks) return "timer rollback (fault inside the image)";
  return "none needed";
}

// Forwards everything to the recorder and carries out the mission's faults.
class Injector final : public kernel::Observer {
 public:
  Injector(RunRecorder& recorder, const Mission& mission, Nanos alignment, Helper& helper, std::uint32_t keep)
      : rec_(recorder), mission_(mission), alignment_(alignment), helper_(helper), keep_(keep) {
    for (const Planned& p : mission.faults) {
      outcomes_.push_back(Outcome{.mission = mission.index, .fault = p});
    }
  }
  void attach(kernel::Kernel* k) { k_ = k; }

  void on_publication(const kernel::Publication& p) override { rec_.on_publication(p); }
  void on_checkpoint(Generation g, const broker::Broker& q) override { rec_.on_checkpoint(g, q); }
  void on_restore(Generation g, const broker::Broker& q) override { rec_.on_restore(g, q); }
  // A recovery's real duration: from the injection to the first control update the kernel routes after the
  // first rollback or cold restart that followed it (the vehicle controlled again).
  void on_control_update(Nanos t, Nanos wall) override {
    rec_.on_control_update(t, wall);
    if (!timing_ || !recovery_began_ || wall < fired_wall_) return;
    outcomes_[*timing_].recovery_ms = std::chrono::duration<double, std::milli>(wall - fired_wall_).count();
    timing_.reset();
  }
  void on_sr_event(const SrEvent& e) override {
    rec_.on_sr_event(e);
    if (timing_ && (e.kind == SrEventKind::Rollback || e.kind == SrEventKind::ColdRestart)) recovery_began_ = true;
  }
  void on_step(std::uint64_t step, Nanos t, SrMode mode) override {
    rec_.on_step(step, t, mode);
    if (k_ == nullptr) return;
    const Nanos flight = t - alignment_;
    maybe_evaluate(flight, false);
    advance(flight, mode, std::nullopt, Generation{});
  }
  void on_image_phase(kernel::ImagePhase phase, Generation g) override {
    if (k_ == nullptr) return;
    advance(k_->now() - alignment_, std::nullopt, phase, g);
  }

  // After the run: the last fault judged against how the mission ended.
  std::vector<Outcome> finish(const kernel::RunOutcome& out, const proto::RunSummary& s, bool lost, bool hung) {
    if (evaluating_) {
      Outcome& o = outcomes_[*evaluating_];
      if (is_terminal(o.fault.kind)) {
        const bool expected = o.fault.kind == FaultKind::KillDriver
                                  ? out.reason == kernel::StopReason::ServiceFailed &&
                                        out.detail.find("output_driver") != std::string::npos
                                  : out.reason == kernel::StopReason::PlantExited;
        o.path = "clean stop, exit 1: " + std::string(kernel::to_string(out.reason)) + ": " + out.detail;
        o.recovered = expected && kernel::is_failure(out.reason);
        if (!o.recovered) o.note = "expected the run to end for it";
        if (s.max_v() >= 1.0 && max_v_at_fire_ < 1.0) o.unsafe = true;
        evaluating_.reset();
      } else {
        evaluate(*evaluating_, Counters::of(k_->sr_stats()), s.max_v(), /*final=*/true);
      }
    }
    const bool terminal_mission = std::any_of(outcomes_.begin(), outcomes_.end(), [](const Outcome& o) {
      return o.fired && is_terminal(o.fault.kind);
    });
    const bool completed = out.reason == kernel::StopReason::MissionDone && s.mission_completed() && !lost;
    if (!terminal_mission && !completed) {
      // The mission should have completed: the last fault before it stopped is held responsible.
      for (auto it = outcomes_.rbegin(); it != outcomes_.rend(); ++it) {
        if (!it->fired) continue;
        it->unsafe = true;
        it->recovered = false;
        it->note += (it->note.empty() ? "" : "; ") + std::string("mission not completed: ") +
                    std::string(kernel::to_string(out.reason)) + ": " + out.detail;
        break;
      }
    }
    if (s.max_v() >= 1.0 && std::none_of(outcomes_.begin(), outcomes_.end(), [](const Outcome& o) { return o.unsafe; })) {
      for (auto it = outcomes_.rbegin(); it != outcomes_.rend(); ++it) {
        if (it->fired) {
          it->unsafe = true;
          it->note += "; max V " + std::to_string(s.max_v());
          break;
        }
      }
    }
    if (hung) {
      for (auto it = outcomes_.rbegin(); it != outcomes_.rend(); ++it) {
        if (it->fired) {
          it->hung = true;
          break;
        }
      }
    }
    return outcomes_;
  }

 private:
  void advance(Nanos flight, std::optional<SrMode> mode, std::optional<kernel::ImagePhase> phase, Generation g) {
    if (next_ >= outcomes_.size()) return;
    Outcome& o = outcomes_[next_];
    if (flight < o.fault.at) return;
    if (flight > o.fault.at + std::chrono::seconds{60}) {
      o.note = "not injected: its phase or a target did not come within 60 s of flight";
      ++next_;
      return;
    }
    bool match = false;
    switch (o.fault.where) {
      case Where::MC: match = mode && *mode == SrMode::MC; break;
      case Where::SecureInterval: match = mode && in_secure_interval(*mode); break;
      case Where::CheckpointSnapshotsSent: match = phase == kernel::ImagePhase::CheckpointSnapshotsSent; break;
      case Where::CheckpointTaken: match = phase == kernel::ImagePhase::CheckpointTaken; break;
      case Where::RollbackKilled: match = phase == kernel::ImagePhase::RollbackKilled; break;
      case Where::RollbackResumesSent: match = phase == kernel::ImagePhase::RollbackResumesSent; break;
    }
    if (!match) return;
    // Inside a rollback `g` is the generation being restored; inside a checkpoint it is not committed yet
    // (no image_pids): the image faults then hit the newest committed generation.
    const bool restoring = phase == kernel::ImagePhase::RollbackKilled || phase == kernel::ImagePhase::RollbackResumesSent;
    const std::vector<int> pids = targets(o.fault, restoring ? std::optional(g) : std::nullopt);
    if (pids.empty()) return;  // e.g. no image yet after a cold restart: stays armed
    if (evaluating_) maybe_evaluate(flight, true);
    // The generations an image fault leaves whole: all but the one it hits (the one being restored, else the
    // newest). Inside a checkpoint by written pages the generation being made depends on the newest one's image
    // too, so with one generation in the store (after a cold restart or a fallback) none is left.
    const std::vector<Generation> gens = k_->generations();
    const std::optional<Generation> hit = restoring ? std::optional(g)
                                          : gens.empty() ? std::nullopt
                                                         : std::optional(gens.back());
    others_at_fire_ = static_cast<std::size_t>(std::ranges::count_if(gens, [&](Generation x) { return x != hit; }));
    const int sig = o.fault.kind == FaultKind::HangLive || o.fault.kind == FaultKind::StopImage ||
                            o.fault.kind == FaultKind::StallPlant
                        ? SIGSTOP
                        : SIGKILL;
    for (const int pid : pids) ::kill(pid, sig);
    if (o.fault.kind == FaultKind::StallPlant) helper_.cont_after(pids.front(), std::chrono::seconds{1});
    o.fired = true;
    o.fired_at_s = to_seconds(flight).count();
    o.note = std::to_string(pids.size()) + " process" + (pids.size() == 1 ? "" : "es") + " (pid";
    for (const int pid : pids) o.note += " " + std::to_string(pid);
    o.note += ")";
    before_ = Counters::of(k_->sr_stats());
    max_v_at_fire_ = current_max_v();
    fired_at_ = flight;
    fired_wall_ = sys::monotonic_now();
    timing_ = next_;
    recovery_began_ = false;
    fired_pids_ = pids;
    seen_back_ = false;
    evaluating_ = next_;
    ++next_;
  }

  std::vector<int> targets(const Planned& p, std::optional<Generation> g) {
    std::vector<int> pids;
    const auto live = [&](std::string_view name) {
      if (const auto id = k_->find_service(name)) {
        const kernel::ServiceStats st = k_->stats(*id);
        if (st.alive && st.pid > 0) pids.push_back(st.pid);
      }
    };
    const auto id = k_->find_service(p.target);
    switch (p.kind) {
      case FaultKind::KillLive:
      case FaultKind::HangLive: live(p.target); break;
      case FaultKind::KillImage:
      case FaultKind::StopImage: {
        if (!id) break;
        const std::vector<Generation> gens = k_->generations();
        if (gens.empty()) break;
        pids = k_->image_pids(*id, g.value_or(gens.back()));
        break;
      }
      case FaultKind::KillImages:
        if (id) pids = k_->image_pids(*id);
        break;
      case FaultKind::KillGroup:
        if (!id) break;
        pids = k_->image_pids(*id);
        if (pids.empty()) break;  // a group with images: else it is only a KillLive
        live(p.target);
        break;
      case FaultKind::KillDriver: live("output_driver"); break;
      case FaultKind::StallPlant:
      case FaultKind::KillPlant:
        if (const auto pid = k_->plant_pid()) pids.push_back(*pid);
        break;
    }
    return pids;
  }

  double current_max_v() {
    proto::RunSummary s;
    rec_.fill(s, k_->now());
    return s.max_v();
  }

  // The fault in flight is judged once its target has had time to come back (10 s of flight, or at once
  // when the next one is about to fire).
  void maybe_evaluate(Nanos flight, bool now) {
    if (!evaluating_) return;
    Outcome& o = outcomes_[*evaluating_];
    if (is_terminal(o.fault.kind)) return;  // judged by how the run ends
    note_if_back(o);
    if (!now && flight < fired_at_ + std::chrono::seconds{10}) return;
    if (!now && k_->mode() == SrMode::RB) return;
    evaluate(*evaluating_, Counters::of(k_->sr_stats()), current_max_v(), false, /*next_fault=*/now);
  }

  // Whether the fault's target has been seen alive in a process that the fault did not hit, at any step since it
  // fired. A verdict taken when the next fault is about to fire may fall in a rollback, when the target's live
  // process is legitimately gone (the rollback has killed it and not yet resumed its image): what counts is
  // that it came back after this fault, not where the next one finds it.
  void note_if_back(const Outcome& o) {
    if (seen_back_ || o.fault.kind == FaultKind::StallPlant) return;
    const auto id = k_->find_service(o.fault.target);
    if (!id) return;
    const kernel::ServiceStats st = k_->stats(*id);
    seen_back_ = st.alive && st.pid > 0 && std::ranges::find(fired_pids_, st.pid) == fired_pids_.end();
  }

  // `final`: the mission has ended; `next_fault`: the next fault is about to fire. Either may come before the
  // target is back, and then the fault is not judged (it may still be recovering); 10 s of flight without it
  // back is a failure.
  void evaluate(std::size_t index, const Counters& after, double max_v, bool final, bool next_fault = false) {
    Outcome& o = outcomes_[index];
    // No rollback or cold restart since it fired: a later one (the SR cycle's) is not this fault's recovery.
    if (timing_ == index && !recovery_began_) timing_.reset();
    o.path = recovery_path(before_, after);
    note_if_back(o);
    bool back = true;
    if (o.fault.kind == FaultKind::StallPlant) {
      back = final || k_->plant_pid().has_value();
    } else if (const auto id = k_->find_service(o.fault.target)) {
      // After the run the services are shut down: only what was seen during it counts.
      back = seen_back_ || (!final && k_->stats(*id).alive);
    }
    const Verdict v = judge(VerdictInput{.kind = o.fault.kind,
                                         .target = o.fault.target,
                                         .path = o.path,
                                         .back = back,
                                         .ended = final,
                                         .next_fault = next_fault,
                                         .stopped = k_->stop_reason().has_value(),
                                         .keep = keep_,
                                         .others_at_fire = others_at_fire_,
                                         .max_v = max_v,
                                         .max_v_at_fire = max_v_at_fire_});
    o.recovered = v.recovered;
    o.unsafe = o.unsafe || v.unsafe;
    o.not_judged = v.not_judged;
    o.note += v.note;
    if (v.unsafe) {
      // What the kernel believed of the target when the vehicle was lost: the clue to an unexplained case.
      if (const auto id = k_->find_service(o.fault.target)) {
        const kernel::ServiceStats st = k_->stats(*id);
        o.note += "; '" + o.fault.target + "' then " + (st.alive ? "alive" : "dead") + ", pid " + std::to_string(st.pid) +
                  ", mode " + std::string(to_string(k_->mode()));
      }
    }
    evaluating_.reset();
  }

  RunRecorder& rec_;
  [[maybe_unused]] const Mission& mission_;  // clang: otherwise an unused private field
  Nanos alignment_;
  Helper& helper_;
  std::uint32_t keep_;  // sr.keep_generations
  kernel::Kernel* k_ = nullptr;
  std::vector<Outcome> outcomes_;
  std::size_t next_ = 0;
  std::optional<std::size_t> evaluating_;
  Counters before_{};
  double max_v_at_fire_ = 0;
  std::size_t others_at_fire_ = 0;  // generations in the store the fault in flight did not hit, when it fired
  Nanos fired_at_{0};
  Nanos fired_wall_{0};                 // CLOCK_MONOTONIC at the injection (the clock of on_control_update)
  std::optional<std::size_t> timing_;   // the fault whose recovery is being timed (until its next controls)
  bool recovery_began_ = false;         // a rollback or cold restart since it fired
  std::vector<int> fired_pids_;  // the processes the fault in flight hit
  bool seen_back_ = false;       // its target seen alive in another process since (note_if_back)
};

// What the job's missions leave behind, against the baseline its first mission sets (libraries' one-time
// state): no child of this process (the kernel is a subreaper: whatever it started and lost would be ours
// now), no fd above the baseline, RSS (a sanitizer build: heap) within 64 MiB of it.
class LeakCheck {
 public:
  LeakCheck() : fds_before_(count_fds()) {}

  // After a mission: "" or what it left (children left are killed now).
  std::string after_mission() {
    std::string leak;
    std::vector<int> left = children();
    for (int i = 0; i < 20 && !left.empty(); ++i) {  // zombies being reaped: give them 1 s
      std::this_thread::sleep_for(std::chrono::milliseconds{50});
      left = children();
    }
    if (!left.empty()) {
      leak += std::to_string(left.size()) + " processes left (killed now)";
      for (const int pid : left) ::kill(pid, SIGKILL);
    }
    const std::size_t fds = count_fds();
    const long rss = memory_kb();
    if (!has_baseline_) {
      // The first mission sets the baseline; said if it grew.
      has_baseline_ = true;
      fd_baseline_ = fds;
      rss_baseline_ = rss;
      if (fds > fds_before_) {
        std::fprintf(stderr, "rejuv faults: fds %zu before the first mission, %zu after (baseline)\n", fds_before_, fds);
      }
    } else if (fds > fd_baseline_) {
      leak += (leak.empty() ? "" : ", ") + std::to_string(fds - fd_baseline_) + " fds above the baseline";
    }
    if (rss > rss_baseline_ + 64 * 1024) {
      leak += (leak.empty() ? "" : ", ") + std::string(kMemoryName) + " " + std::to_string(rss / 1024) +
              " MiB (baseline " + std::to_string(rss_baseline_ / 1024) + " MiB)";
    }
    return leak;
  }

 private:
  std::size_t fds_before_;
  bool has_baseline_ = false;  // not an optional: g++ 12 -Wmaybe-uninitialized misreads one in this class
  std::size_t fd_baseline_ = 0;
  long rss_baseline_ = 0;
};

// The kernel of a job's mission: the plant's clock, no network port, the job's DDS domain and CPU, its log.
kernel::KernelOptions mission_options(const JobConfig& config, std::FILE* log) {
  kernel::KernelOptions options;
  options.time_master = kernel::TimeMaster::Plant;
  options.service_dir = service_dir();
  options.repo_root = REJUV_SOURCE_DIR;
  options.dds_domain = config.dds_domain;
  options.network_port = 0;
  options.idle_deadline = std::chrono::seconds{3};
  if (config.realtime) {
    // As `rejuv run --realtime`: the wall clock, the graph's real-time plan, no pinning of the whole graph.
    options.clock = kernel::ClockMode::Realtime;
    options.placement = kernel::KernelOptions::Placement::Auto;
  } else {
    options.placement = kernel::KernelOptions::Placement::Cpu;
    options.cpu = config.cpu;
  }
  options.log = log;
  options.verbose = std::getenv("REJUV_FAULTS_VERBOSE") != nullptr;  // every checkpoint and rollback in the job log
  options.charge = config.charge;
  return options;
}

// One mission flown with its faults.
struct Flown {
  std::vector<Outcome> outcomes;
  kernel::RunOutcome run;
  bool hung = false;  // the watchdog stopped it
};

// Flies `mission` in a new kernel under the watchdog; an error (the graph, its reference run or the kernel
// could not be made) fails all its faults.
Result<Flown, std::string> fly_mission(const JobConfig& config, const Mission& mission, Helper& helper,
                                       std::FILE* log) {
  auto graph = launch::load_launch(config.graph);
  if (!graph) return fail(graph.error().to_string());
  auto reference = run_reference(*graph, std::nullopt);
  if (!reference) return fail(reference.error());
  const Nanos alignment = reference->alignment;
  const std::uint32_t keep = launch::keep_generations(graph->graph.sr());
  RunRecorder recorder(std::move(*reference), nullptr, RunRecorder::Progress::Off);
  Injector injector(recorder, mission, alignment, helper, keep);
  auto k = kernel::Kernel::create(std::move(*graph), mission_options(config, log), &injector);
  if (!k) return fail("kernel: " + k.error().to_string());
  injector.attach(k->get());
  recorder.on_vehicle_lost([kp = k->get()] { kp->request_stop(); });
  if (log != nullptr) std::fprintf(log, "---- mission %u ----\n", mission.index), std::fflush(log);
  helper.arm_watchdog(config.mission_wall_bound);
  auto out = (*k)->run();
  helper.disarm_watchdog();
  Flown flown{.outcomes = {},
              .run = out ? *out
                         : kernel::RunOutcome{.reason = kernel::StopReason::ServiceFailed, .detail = out.error().to_string()},
              .hung = helper.expired()};
  proto::RunSummary summary;
  recorder.fill(summary, flown.run.sim_time);
  flown.outcomes = injector.finish(flown.run, summary, recorder.lost().has_value(), flown.hung);
  k->reset();
  helper.clear_conts();
  if (log != nullptr) std::fflush(log);
  return flown;
}

void print_mission(const Mission& mission, const Flown& flown, const std::string& leak) {
  std::fprintf(stderr, "rejuv faults: mission %u: %s%s%s (%.1f s wall)%s%s\n", mission.index,
               std::string(kernel::to_string(flown.run.reason)).c_str(), flown.run.detail.empty() ? "" : ": ",
               flown.run.detail.c_str(), to_seconds(flown.run.wall_time).count(), flown.hung ? " HUNG" : "",
               leak.empty() ? "" : (" LEAK: " + leak).c_str());
}

}  // namespace

std::vector<Outcome> run_job(const JobConfig& config, const std::vector<Mission>& missions) {
  std::vector<Outcome> all;
  std::FILE* log = config.log.empty() ? nullptr : std::fopen(config.log.c_str(), "w");
  Helper helper;
  LeakCheck leaks;
  for (const Mission& mission : missions) {
    auto flown = fly_mission(config, mission, helper, log);
    if (!flown) {
      // Counted as injected and not recovered, so that a campaign whose missions could not fly fails.
      for (const Planned& p : mission.faults) {
        all.push_back(Outcome{.mission = mission.index, .fault = p, .fired = true,
                              .note = "the mission could not be flown: " + flown.error()});
      }
      continue;
    }
    const std::string leak = leaks.after_mission();
    for (Outcome& o : flown->outcomes) {
      if (!leak.empty() && o.fired) {
        o.leaked = true;
        o.note += "; mission leak: " + leak;
      }
      all.push_back(std::move(o));
    }
    print_mission(mission, *flown, leak);
    // SIGINT or SIGTERM from outside (not the watchdog's): the campaign is being stopped, no more missions.
    if (flown->run.reason == kernel::StopReason::Signal && !flown->hung) break;
  }
  if (log != nullptr) std::fclose(log);
  return all;
}

}  // namespace rejuv::cli::faults
