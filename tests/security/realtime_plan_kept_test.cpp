// The real-time plan is kept for the whole flight, not only applied when a service becomes Ready: a service of
// the control chain found off SCHED_FIFO (a refusal that raced its move into `live/`, or any process that moved
// it) is given SCHED_FIFO again by the kernel's real-time loop (Supervisor::keep_realtime_plan). A chain service
// left SCHED_OTHER for the rest of a flight is starved by any load beside it, and the vehicle with it.
//
// launch/quad_square in real time (SR and the worst-case control attack on), the real kernel, flight services and
// plant. From the kernel's own thread (on_step, every 100 ms of flight), `sensors`' live process is moved to
// SCHED_OTHER in the secure interval; judged by effect: the same process is seen at SCHED_FIFO again while it is
// still the live one, and the vehicle stays in the safety set. No timing is asserted.
#include <gtest/gtest.h>
#include <sched.h>

#include <cstdio>
#include <string>

#include "observed_flight.hpp"

namespace rejuv::testing {
namespace {

using kernel::Kernel;
using kernel::StopReason;

constexpr std::chrono::seconds kFlight{12};

bool at_fifo(pid_t pid) {
  const int policy = ::sched_getscheduler(pid);
  return policy >= 0 && (policy & ~SCHED_RESET_ON_FORK) == SCHED_FIFO;
}

// Moves the target's live process to SCHED_OTHER when it has been the live one, at SCHED_FIFO, for a look in
// SC (so the catch-up, which runs the chain SCHED_OTHER by design, is over), then watches it: back at
// SCHED_FIFO while still live (restored), or replaced first by a rollback (inconclusive: tried again).
class Knocker final : public kernel::Observer {
 public:
  Knocker(std::string target, Nanos from) : target_(std::move(target)), from_(from) {}
  void attach(Kernel* k) { k_ = k; }
  void on_step(std::uint64_t, Nanos t, SrMode mode) override {
    if (k_ == nullptr || t < from_) return;
    const auto id = k_->find_service(target_);
    if (!id) return;
    const kernel::ServiceStats st = k_->stats(*id);
    if (!st.alive || st.pid <= 0) return;
    if (knocked_ > 0) {
      if (st.pid != knocked_) {
        ++replaced_;
        knocked_ = -1;
      } else if (at_fifo(knocked_)) {
        ++restored_;
        knocked_ = -1;
      }
      return;
    }
    const bool settled = mode == SrMode::SC && st.pid == seen_ && at_fifo(st.pid);
    seen_ = mode == SrMode::SC ? st.pid : -1;
    if (!settled) return;
    const sched_param param{.sched_priority = 0};
    if (::sched_setscheduler(st.pid, SCHED_OTHER, &param) == 0 && !at_fifo(st.pid)) {
      knocked_ = st.pid;
      ++knocks_;
    }
  }
  [[nodiscard]] int knocks() const { return knocks_; }
  [[nodiscard]] int restored() const { return restored_; }
  [[nodiscard]] int replaced() const { return replaced_; }

 private:
  std::string target_;
  Nanos from_;
  Kernel* k_ = nullptr;
  pid_t seen_ = -1;
  pid_t knocked_ = -1;
  int knocks_ = 0, restored_ = 0, replaced_ = 0;
};

TEST(RealtimePlanKept, ChainServiceMovedOffFifo_GivenItAgain_VehicleSafe) {
  if (::geteuid() != 0) GTEST_SKIP() << "the flight graph's sandbox and SCHED_FIFO need root here";
  int knocks = 0, restored = 0, replaced = 0;
  mission::ObservedFlight f;
  ASSERT_NO_FATAL_FAILURE(mission::fly_observed<Knocker>(
      true, kFlight, [](Nanos alignment) { return Knocker("sensors", alignment + Nanos{std::chrono::seconds{1}}); },
      [&](const Kernel&, const Knocker& knocker) {
        knocks = knocker.knocks();
        restored = knocker.restored();
        replaced = knocker.replaced();
      },
      f));
  std::printf("[ real time ] sensors moved to SCHED_OTHER %d times: %d given SCHED_FIFO again while live, %d replaced "
              "by a rollback first; max V %.3f\n",
              knocks, restored, replaced, f.summary.max_v());

  const std::string log = f.log.text();
  if (log.find("'sensors' refused SCHED_FIFO") != std::string::npos &&
      log.find("'sensors' at SCHED_FIFO again") == std::string::npos) {
    GTEST_SKIP() << "another real-time kernel holds this machine's real-time budget:\n" << f.log.lines_with("real-time");
  }
  EXPECT_EQ(f.outcome->reason, StopReason::Duration) << f.outcome->detail;
  ASSERT_GT(knocks, 0) << "sensors was never seen settled at SCHED_FIFO in SC:\n" << f.log.lines_with("real-time");
  EXPECT_GT(restored, 0) << "a chain service moved off SCHED_FIFO stayed off it while live (" << replaced
                         << " replaced by a rollback first)";
  EXPECT_LT(f.summary.max_v(), 1.0) << "the vehicle left the safety set";
}

}  // namespace
}  // namespace rejuv::testing
