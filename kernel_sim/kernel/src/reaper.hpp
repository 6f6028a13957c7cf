// The processes the kernel is done with (DESIGN §7): the incarnations a rollback retired — put out of its way
// under SCHED_IDLE and killed at the next safe point — and the processes killed and not reaped yet, which hold
// their uid's process slots (max_processes, RLIMIT_NPROC) until they are. One owner: the image coordinator
// (images.cpp, rollback.cpp) and the shutdown (supervisor.cpp); the sandbox's stray sweep asks it whose a pid is.
#pragma once

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <limits>
#include <vector>

#include "rejuv/core/time.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::kernel {

class Reaper {
 public:
  // A live incarnation a rollback retires. Not signalled: a signal wakes its victim, which then takes the CPU
  // at once (8 SIGKILLs 0.68 ms: its exit runs inline; 8 SIGSTOPs 0.09 ms; 8 switches to SCHED_IDLE 0.013 ms;
  // /tmp micro-benchmark, one CPU). Under SCHED_IDLE it runs only when nothing else on its CPU can; where the
  // switch is refused, it is stopped. Killed by kill_retired.
  void retire(sys::ChildProcess p) {
    if (!sys::idle_priority(p.pid())) (void)p.signal(SIGSTOP);
    retired_.push_back(std::move(p));
  }
  // At a safe point after the rollback. SCHED_IDLE is undone before the kill: left idle, on a loaded machine
  // they took seconds to die while holding their uid's process slots (60 of the worker's 64 in
  // Images.HundredRollbacks on 2 cores beside six multiproc tests, where its next resumed image could not
  // start its thread).
  void kill_retired() {
    for (sys::ChildProcess& p : retired_) {
      (void)sys::normal_priority(p.pid());
      kill(std::move(p));
    }
    retired_.clear();
  }
  // Killed now, at its own priority, reaped later (reap, at a safe point). A victim's exit runs at once
  // whatever its priority (8 kills 0.68 ms, 0.69 ms at nice 19), but lowered first, on a loaded machine the
  // ones that did not run at once took seconds to die, holding their uid's process slots all along.
  void kill(sys::ChildProcess p) {
    (void)p.signal(SIGKILL);
    dying_.push_back(std::move(p));
  }
  void reap() {
    std::erase_if(dying_, [](sys::ChildProcess& p) {
      auto status = p.try_wait();
      return !status || *status;
    });
  }
  // Backpressure before a checkpoint or a rollback, which both need new processes: waits (until `until`, wall
  // clock) while more are dying than the slack allows.
  void set_slack(std::uint64_t slack) { slack_ = slack; }
  void settle(Nanos until) {
    reap();
    while (dying_.size() > slack_ && sys::monotonic_now() < until) {
      (void)sys::wait_fd(dying_.front().pidfd(), sys::WaitFor::Readable, until - sys::monotonic_now());
      reap();
    }
  }
  // Shutdown: everything killed and reaped, now.
  void kill_all_and_reap() {
    kill_retired();
    for (sys::ChildProcess& p : dying_) p.kill_and_reap();
    dying_.clear();
  }
  [[nodiscard]] bool knows(pid_t pid) const {
    const auto in = [&](const std::vector<sys::ChildProcess>& v) {
      return std::any_of(v.begin(), v.end(), [&](const sys::ChildProcess& c) { return c.pid() == pid; });
    };
    return in(dying_) || in(retired_);
  }

 private:
  std::vector<sys::ChildProcess> retired_;
  std::vector<sys::ChildProcess> dying_;
  std::uint64_t slack_ = std::numeric_limits<std::uint64_t>::max();
};

}  // namespace rejuv::kernel
