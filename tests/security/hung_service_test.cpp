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

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <ostream>
#include <string>

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

}  // namespace
}  // namespace rejuv::testing
