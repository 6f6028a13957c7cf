// A service of the control chain that hangs in flight (SIGSTOP: stopped, neither dead nor answering) is found and
// rolled back at once, in REAL TIME as in LOCKSTEP, instead of leaving the vehicle on its last output until the
// secure interval ends and the next timer rollback comes (docs/design.md §7 "Faults"). launch/quad_square (SR and
// the worst-case control attack on), the real kernel, flight services and plant; the live process of `ekf2` (the
// estimate the safety controller flies on) or of `safety_control` (the controller of the secure interval) is
// stopped in the secure interval 4 s into the flight.
//
// In real time the kernel sends a Sync to a service that has frames it has not reported and kills one that does
// not answer it with its Idle within its deadline (Supervisor::watch_liveness; the chain's, at SCHED_FIFO); in
// lockstep the idle deadline does it. Judged by effect: the stopped process is gone, the service lives on in
// another process, the kernel named the hang, a rollback followed, and the vehicle stayed in the safety set. No
// timing is asserted.
#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <semaphore>
#include <string>
#include <thread>
#include <vector>

#include "observed_flight.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using kernel::Kernel;
using kernel::StopReason;

constexpr std::chrono::seconds kFlight{14};
constexpr std::chrono::seconds kStopAfter{4};  // into the flight (after the alignment)

// Stops the target's live process once, from the kernel's own thread (on_step): at the first step in the secure
// interval's SC `at` or later into the kernel clock. There no rejuvenation timer runs (it is armed in MC, T_MC
// 0.2 s), so before the watch nothing would find the hang until the interval ended, and the safety controller
// flew on the stale estimate meanwhile.
class Stopper final : public kernel::Observer {
 public:
  Stopper(std::string target, Nanos at) : target_(std::move(target)), at_(at) {}
  void attach(Kernel* k) { k_ = k; }
  void on_step(std::uint64_t, Nanos t, SrMode mode) override {
    if (k_ == nullptr || stopped_pid_ > 0 || t < at_ || mode != SrMode::SC) return;
    const auto id = k_->find_service(target_);
    if (!id) return;
    const kernel::ServiceStats st = k_->stats(*id);
    if (!st.alive || st.pid <= 0) return;
    if (::kill(st.pid, SIGSTOP) == 0) {
      stopped_pid_ = st.pid;
      rollbacks_before_ = k_->sr_stats().rollbacks + k_->sr_stats().cold_restarts;
    }
  }
  [[nodiscard]] pid_t stopped_pid() const { return stopped_pid_; }
  [[nodiscard]] std::uint64_t rollbacks_before() const { return rollbacks_before_; }

 private:
  std::string target_;
  Nanos at_;
  Kernel* k_ = nullptr;
  pid_t stopped_pid_ = -1;
  std::uint64_t rollbacks_before_ = 0;
};

struct HungCase {
  bool realtime;
  const char* target;
};

void PrintTo(const HungCase& c, std::ostream* os) {
  *os << c.target << (c.realtime ? " in real time" : " in lockstep");
}

class HungService : public ::testing::TestWithParam<HungCase> {};

TEST_P(HungService, StoppedInTheSecureInterval_FoundKilledAndRolledBack_VehicleStaysSafe) {
  if (::geteuid() != 0) GTEST_SKIP() << "the flight graph's sandbox needs root here";
  const bool realtime = GetParam().realtime;
  const std::string target = GetParam().target;
  kernel::SrStats sr{};
  kernel::ServiceStats service{};
  pid_t stopped = -1;
  std::uint64_t rollbacks_before = 0;
  mission::ProcStat after{};
  mission::ObservedFlight f;
  ASSERT_NO_FATAL_FAILURE(mission::fly_observed<Stopper>(
      realtime, kFlight, [&](Nanos alignment) { return Stopper(target, alignment + Nanos{kStopAfter}); },
      [&](const Kernel& k, const Stopper& stopper) {
        sr = k.sr_stats();
        if (const auto id = k.find_service(target)) service = k.stats(*id);
        stopped = stopper.stopped_pid();
        rollbacks_before = stopper.rollbacks_before();
        if (stopped > 0) after = mission::proc_stat(stopped);
      },
      f));
  std::printf("[ %s ] stopped %s pid %d; max V %.3f; %llu rollbacks, %llu fallbacks, %llu cold restarts\n",
              realtime ? "real time" : "lockstep", target.c_str(), stopped, f.summary.max_v(),
              static_cast<unsigned long long>(sr.rollbacks), static_cast<unsigned long long>(sr.fallbacks),
              static_cast<unsigned long long>(sr.cold_restarts));

  ASSERT_GT(stopped, 0) << target << " was never stopped: no SC step " << kStopAfter.count() << " s into the flight";
  EXPECT_EQ(f.outcome->reason, StopReason::Duration) << f.outcome->detail;
  // Found and killed as hung: the process the test stopped is gone (or a zombie nobody will run again).
  EXPECT_TRUE(after.state == '?' || after.state == 'Z' || after.parent != ::getpid())
      << "the stopped " << target << " (pid " << stopped << ") is still there, state " << after.state;
  const std::string named = f.log.lines_with("killing '" + target + "'");
  EXPECT_NE(named.find(realtime ? "no Idle within" : "not idle within the idle deadline"), std::string::npos)
      << f.log.lines_with(target);
  // Rolled back (a restored image, or a cold restart): the service flew on in another process.
  EXPECT_GT(sr.rollbacks + sr.cold_restarts, rollbacks_before);
  EXPECT_NE(service.pid, stopped);
  EXPECT_LT(f.summary.max_v(), 1.0) << "the vehicle left the safety set";
}

INSTANTIATE_TEST_SUITE_P(ClocksAndTargets, HungService,
                         ::testing::Values(HungCase{true, "ekf2"}, HungCase{false, "ekf2"},
                                           HungCase{true, "safety_control"}, HungCase{false, "safety_control"}),
                         [](const ::testing::TestParamInfo<HungCase>& p) {
                           return std::string(p.param.realtime ? "RealTime_" : "Lockstep_") + p.param.target;
                         });

// ---- a service starved of the CPU is not hung ----

// The calling thread pinned to `cpu` at SCHED_FIFO 55 — above the control chain (50, 45) and every image,
// below the kernel (60) and the plant (70); false when refused.
bool hold_at_fifo55(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  const sched_param param{.sched_priority = 55};
  return ::pthread_setaffinity_np(::pthread_self(), sizeof(set), &set) == 0 &&
         ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &param) == 0;
}

// Spins on the calling thread for `d`.
void spin_for(Nanos d) {
  const auto until = std::chrono::steady_clock::now() + d;
  while (std::chrono::steady_clock::now() < until) {
  }
}

// Holds every CPU at SCHED_FIFO 55 — above the control chain (50, 45) and every image, below the kernel (60)
// and the plant (70) — for kHog at a time, kBursts times at least kBurstEvery apart from `at` on the kernel
// clock: at a step, or (`phase`) as the kernel reaches that point of a checkpoint or a rollback, where it
// then waits for its services' answers. What it waits for is runnable and gets no CPU, as on a machine whose
// real-time work outranks it (or whose virtual CPUs stall) while the kernel runs on. One thread per CPU,
// pinned and at SCHED_FIFO 55 from the kernel's first step on, parked until a burst releases it: released
// from the kernel's thread (on_step, on_image_phase), it takes its CPU at once, before what the kernel just
// asked for can answer (a thread started at the burst came too late on a loaded machine: the images had
// answered). Joined at the end.
class Starver final : public kernel::Observer {
 public:
  static constexpr int kBursts = 4;
  static constexpr Nanos kHog{std::chrono::milliseconds{150}};
  static constexpr Nanos kBurstEvery{std::chrono::milliseconds{1500}};

  explicit Starver(Nanos at, std::optional<kernel::ImagePhase> phase = std::nullopt)
      : next_(at), phase_(phase) {}
  Starver(Starver&&) = default;
  Starver& operator=(Starver&&) = delete;
  Starver(const Starver&) = delete;
  Starver& operator=(const Starver&) = delete;
  ~Starver() override { join(); }
  void attach(Kernel*) {}

  void on_step(std::uint64_t, Nanos t, SrMode) override {
    t_ = t;
    park_hogs();
    if (!phase_) maybe_burst();
  }
  void on_image_phase(kernel::ImagePhase phase, Generation) override {
    park_hogs();
    if (phase_ && phase == *phase_) maybe_burst();
  }
  void join() const {
    stop_.store(true);
    for (const std::unique_ptr<Hog>& h : hogs_) h->go.release();
    for (const std::unique_ptr<Hog>& h : hogs_) {
      if (h->thread.joinable()) h->thread.join();
    }
  }
  [[nodiscard]] int bursts() const { return bursts_; }
  [[nodiscard]] int held() const { return held_.load(); }
  [[nodiscard]] int refused() const { return refused_.load(); }

 private:
  struct Hog {
    std::counting_semaphore<> go{0};  // a burst
    std::thread thread;
  };
  void park_hogs() {
    if (!hogs_.empty()) return;
    const unsigned cpus = std::max(1U, std::thread::hardware_concurrency());
    for (unsigned cpu = 0; cpu < cpus; ++cpu) {
      hogs_.push_back(std::make_unique<Hog>());
      Hog& hog = *hogs_.back();
      hog.thread = std::thread([this, cpu, &hog] {
        const bool placed = hold_at_fifo55(static_cast<int>(cpu));
        if (!placed) refused_.fetch_add(1);
        for (;;) {
          hog.go.acquire();
          if (stop_.load()) return;
          if (!placed) continue;
          spin_for(kHog);
          held_.fetch_add(1);
        }
      });
    }
  }
  void maybe_burst() {
    if (bursts_ >= kBursts || t_ < next_) return;
    ++bursts_;
    next_ = t_ + kBurstEvery;
    for (const std::unique_ptr<Hog>& h : hogs_) h->go.release();
  }

  Nanos next_;
  std::optional<kernel::ImagePhase> phase_;
  Nanos t_{0};  // the kernel clock at the last step
  int bursts_ = 0;
  std::vector<std::unique_ptr<Hog>> hogs_;
  mutable std::atomic<bool> stop_{false};  // set by a const inspection (join)
  std::atomic<int> held_{0}, refused_{0};
};

// What a starved flight showed: its SR counters, its bursts, and the summary and log (f).
struct Starved {
  kernel::SrStats sr{};
  std::uint64_t images_lost = 0;
  int bursts = 0, held = 0, refused = 0;
  mission::ObservedFlight f;
};

// The square in real time with a Starver (`phase`: when it starves) from kStopAfter into the flight.
void fly_starved(std::optional<kernel::ImagePhase> phase, Starved& out) {
  ASSERT_NO_FATAL_FAILURE(mission::fly_observed<Starver>(
      true, kFlight, [&](Nanos alignment) { return Starver(alignment + Nanos{kStopAfter}, phase); },
      [&](const Kernel& k, const Starver& starver) {
        out.sr = k.sr_stats();
        for (std::size_t i = 0; i < k.service_count(); ++i) {
          out.images_lost += k.stats(ServiceId(i)).images_lost;
        }
        starver.join();  // the hogs end on their own: joined before they are counted
        out.bursts = starver.bursts();
        out.held = starver.held();
        out.refused = starver.refused();
      },
      out.f));
  const auto n = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
  const std::string at = phase ? " at " + std::string(kernel::to_string(*phase)) : "";
  std::printf("[ real time ] %d bursts%s, %d CPU holds (%d refused SCHED_FIFO); max V %.3f; %llu rollbacks, "
              "%llu fallbacks, %llu images lost, %llu checkpoints abandoned, %llu cold restarts\n%s",
              out.bursts, at.c_str(), out.held, out.refused, out.f.summary.max_v(), n(out.sr.rollbacks),
              n(out.sr.fallbacks), n(out.images_lost), n(out.sr.checkpoint_failures), n(out.sr.cold_restarts),
              (out.f.log.lines_with("for a CPU") +
               out.f.log.lines_with("after the snapshot deadline")).c_str());
  ASSERT_EQ(out.refused, 0) << "the hogs could not run at SCHED_FIFO 55: nothing was starved";
  ASSERT_GT(out.bursts, 0);
}

// What every starved flight must show: it flew its duration, nothing was cold-restarted, and the vehicle
// stayed in the safety set.
void expect_flown_through(const Starved& run) {
  EXPECT_EQ(run.f.outcome->reason, StopReason::Duration) << run.f.outcome->detail;
  EXPECT_EQ(run.sr.cold_restarts, 0U);
  EXPECT_LT(run.f.summary.max_v(), 1.0) << "the vehicle left the safety set";
}

TEST(StarvedService, ChainWithoutACpuInRealTime_NotKilledAsHung_VehicleStaysSafe) {
  if (::geteuid() != 0) GTEST_SKIP() << "the flight graph's sandbox and SCHED_FIFO need root here";
  Starved run;
  ASSERT_NO_FATAL_FAILURE(fly_starved(std::nullopt, run));
  const mission::ObservedFlight& f = run.f;
  ASSERT_EQ(run.bursts, Starver::kBursts);
  // The starvation happened and the watch saw it for what it was.
  EXPECT_NE(f.log.lines_with("waiting for a CPU").find("not hung"), std::string::npos) << f.log.text();
  EXPECT_EQ(f.log.lines_with("no Idle within"), "") << "a service killed as hung while it waited for a CPU";
  expect_flown_through(run);
}

// Starved while the rollback waits for its images' Resumed (150 ms, past the 100 ms resume deadline): the
// images are waiting for a CPU, not lost. The rollback waits on for them: no fallback to an older generation,
// no image reported lost (a security event), no cold restart, and the vehicle stays in the safety set.
TEST(StarvedService, ImagesWithoutACpuAtARollback_NotLost_NoFallback_VehicleStaysSafe) {
  if (::geteuid() != 0) GTEST_SKIP() << "the flight graph's sandbox and SCHED_FIFO need root here";
  Starved run;
  ASSERT_NO_FATAL_FAILURE(fly_starved(kernel::ImagePhase::RollbackResumesSent, run));
  const mission::ObservedFlight& f = run.f;
  EXPECT_NE(f.log.lines_with("waiting for a CPU").find("not lost"), std::string::npos) << f.log.text();
  EXPECT_EQ(f.log.lines_with("lost in the store"), "");
  EXPECT_EQ(run.images_lost, 0U);
  EXPECT_EQ(run.sr.fallbacks, 0U) << f.log.lines_with("falling back");
  expect_flown_through(run);
}

// Starved while the checkpoint waits for its Taken (150 ms, past the 100 ms snapshot deadline): the
// checkpoint is abandoned (the vehicle waits with it), but the late services are waiting for a CPU, not hung:
// none is killed, no rollback is forced, nothing is cold-restarted, and the vehicle stays in the safety set.
TEST(StarvedService, ServicesWithoutACpuAtACheckpoint_AbandonedNotKilled_VehicleStaysSafe) {
  if (::geteuid() != 0) GTEST_SKIP() << "the flight graph's sandbox and SCHED_FIFO need root here";
  Starved run;
  ASSERT_NO_FATAL_FAILURE(fly_starved(kernel::ImagePhase::CheckpointSnapshotsSent, run));
  const mission::ObservedFlight& f = run.f;
  EXPECT_GT(run.sr.checkpoint_failures, 0U)
      << "no checkpoint missed its deadline: the starvation did not reach it";
  EXPECT_NE(f.log.lines_with("at the snapshot deadline").find("not hung"), std::string::npos) << f.log.text();
  EXPECT_EQ(f.log.lines_with("no Taken within"), "") << "a service killed as hung while it waited for a CPU";
  expect_flown_through(run);
}

// Lockstep: ekf2 moved to a CPU the kernel is not pinned to, and that CPU held at SCHED_FIFO 55 for kHold, 5
// times its idle deadline (300 ms here): ekf2 is runnable and gets no CPU while a step waits for its Idle.
// The deadline counts the CPU time it had while it is runnable (cpu_wait.hpp), so it is waited for, not
// killed as hung; the step completes once the CPU is free again, and the flight goes on.
class CpuTaker final : public kernel::Observer {
 public:
  static constexpr Nanos kHold{std::chrono::milliseconds{1500}};
  CpuTaker(std::string target, Nanos at) : target_(std::move(target)), at_(at) {}
  CpuTaker(CpuTaker&&) = default;
  CpuTaker& operator=(CpuTaker&&) = delete;
  CpuTaker(const CpuTaker&) = delete;
  CpuTaker& operator=(const CpuTaker&) = delete;
  ~CpuTaker() override { join(); }
  void attach(Kernel* k) { k_ = k; }
  void on_step(std::uint64_t, Nanos t, SrMode) override {
    if (k_ == nullptr || moved_ || t < at_) return;
    const auto id = k_->find_service(target_);
    if (!id) return;
    const kernel::ServiceStats st = k_->stats(*id);
    if (!st.alive || st.pid <= 0) return;
    moved_ = true;
    const int kernel_cpu = ::sched_getcpu();  // a lockstep run is pinned to it (KernelOptions::placement)
    const unsigned cpus = std::thread::hardware_concurrency();
    for (unsigned c = 0; c < cpus; ++c) {
      if (static_cast<int>(c) != kernel_cpu) {
        taken_cpu_ = static_cast<int>(c);
        break;
      }
    }
    if (taken_cpu_ < 0) return;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(taken_cpu_, &set);
    for (const auto& task : fs::directory_iterator("/proc/" + std::to_string(st.pid) + "/task")) {
      if (::sched_setaffinity(std::stoi(task.path().filename().string()), sizeof(set), &set) == 0)
        ++threads_moved_;
    }
    hog_ = std::thread([this] {
      if (!hold_at_fifo55(taken_cpu_)) return;
      held_ = true;
      spin_for(kHold);
    });
  }
  void join() const {
    if (hog_.joinable()) hog_.join();
  }
  [[nodiscard]] int taken_cpu() const { return taken_cpu_; }
  [[nodiscard]] int threads_moved() const { return threads_moved_; }
  [[nodiscard]] bool held() const { return held_.load(); }

 private:
  std::string target_;
  Nanos at_;
  Kernel* k_ = nullptr;
  bool moved_ = false;
  int taken_cpu_ = -1;
  int threads_moved_ = 0;
  mutable std::thread hog_;  // joined by a const inspection (join)
  std::atomic<bool> held_{false};
};

TEST(StarvedService, LockstepServiceWithoutACpuPastItsIdleDeadline_WaitedForNotKilled_VehicleStaysSafe) {
  if (::geteuid() != 0) GTEST_SKIP() << "the flight graph's sandbox and SCHED_FIFO need root here";
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "needs a CPU the kernel is not on";
  constexpr Nanos kIdleDeadline{std::chrono::milliseconds{300}};
  kernel::SrStats sr{};
  int taken = -1, moved = 0;
  bool held = false;
  mission::ObservedFlight f;
  ASSERT_NO_FATAL_FAILURE(mission::fly_observed<CpuTaker>(
      false, kFlight, [&](Nanos alignment) { return CpuTaker("ekf2", alignment + Nanos{kStopAfter}); },
      [&](const Kernel& k, const CpuTaker& taker) {
        taker.join();
        sr = k.sr_stats();
        taken = taker.taken_cpu();
        moved = taker.threads_moved();
        held = taker.held();
      },
      f, [&](kernel::KernelOptions& o) { o.idle_deadline = kIdleDeadline; }));
  std::printf(
      "[ lockstep ] ekf2 (%d threads) on CPU %d, held at SCHED_FIFO for %lld ms: %s; max V %.3f\n%s", moved,
      taken,
      static_cast<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(CpuTaker::kHold).count()),
      held ? "held" : "NOT held", f.summary.max_v(), f.log.lines_with("for a CPU").c_str());
  ASSERT_GE(taken, 0);
  ASSERT_GT(moved, 0);
  ASSERT_TRUE(held) << "the CPU could not be held at SCHED_FIFO 55: nothing was starved";
  EXPECT_NE(f.log.lines_with("'ekf2' waiting for a CPU at the idle deadline"), "") << f.log.text();
  EXPECT_EQ(f.log.lines_with("not idle within the idle deadline"), "")
      << "a service killed as hung while it waited";
  EXPECT_EQ(f.outcome->reason, StopReason::Duration) << f.outcome->detail;
  EXPECT_EQ(sr.cold_restarts, 0U);
  EXPECT_LT(f.summary.max_v(), 1.0) << "the vehicle left the safety set";
}

}  // namespace
}  // namespace rejuv::testing
