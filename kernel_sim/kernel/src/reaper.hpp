// The processes the kernel is done with (docs/design.md §7): the incarnations a rollback retired — stopped at
// once and killed at the next safe point — and the processes killed and not reaped yet, which hold their
// uid's process slots (max_processes, RLIMIT_NPROC) until they are. One owner: the image coordinator
// (rejuvenator.cpp, rollback.cpp) and the shutdown (supervisor.cpp); the Warden's stray sweep asks it whose
// a pid is and hands it the strays it kills.
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
  // A live incarnation a rollback retires: stopped (SIGSTOP) before any image is resumed, so that no thread of
  // a compromised incarnation runs beside the restored one — a group stop reaches every thread, one running on
  // another CPU is interrupted at once, and a stopped process cannot be woken by anything a service can reach
  // (no signal to another process). A stop costs the rollback a few µs per service; a kill would run the
  // victim's exit (its whole address space) on the rollback's critical path. Killed by kill_retired.
  void retire(sys::ChildProcess p) {
    (void)p.signal(SIGSTOP);
    retired_.push_back(std::move(p));
  }
  // At a safe point after the rollback: the stopped incarnations killed (SIGKILL ends a stopped process).
  void kill_retired() {
    for (sys::ChildProcess& p : retired_) kill(std::move(p));
    retired_.clear();
  }
  // Killed now, reaped later (reap, at a safe point): the kill is one system call, the victim's exit runs in
  // its own context and the wait for it is off the vehicle's critical path, however many there are.
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
