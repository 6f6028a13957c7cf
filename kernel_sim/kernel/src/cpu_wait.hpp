// A verdict on a waiting process that counts the CPU it had, not the wall time (docs/design.md §7 "Faults"):
// a process that is runnable — running, or waiting on a run queue — and has had little CPU since its deadline
// began is waiting for the machine (a loaded CPU, a higher real-time priority, a stalled virtual CPU), not
// hung, stopped or gone. Used by the liveness watch (a Sync's Idle), the rollback (an image's Resumed) and
// the checkpoint (a Taken). CpuWait has no clock and reads no /proc: the callers hand it the wall time and
// what the scheduler shows, which cpu_sight reads (cpu_wait.cpp; tests/unit/kernel/cpu_wait_test.cpp).
#pragma once

#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <span>

#include "rejuv/core/time.hpp"

namespace rejuv::kernel {

// What the scheduler gives one process, or several taken together: the CPU time they had since birth
// (summed), and whether one of them is runnable (sys::TaskCpu: running, waiting for a CPU, or in an
// uninterruptible wait inside the OS) rather than asleep by its own call, or stopped.
struct CpuSight {
  Nanos ran{0};
  bool runnable = false;
};

// What the scheduler gives the main threads of `pids` taken together (sys::task_cpu of each): CPU times
// summed, runnable if one is; nullopt when none of them can be read (gone, or never a process).
[[nodiscard]] std::optional<CpuSight> cpu_sight(std::span<const pid_t> pids);
[[nodiscard]] inline std::optional<CpuSight> cpu_sight(pid_t pid) { return cpu_sight(std::span(&pid, 1)); }

// The longest a process with a deadline of `deadline` is waited for while it waits for a CPU: a process the
// machine does not run for that long is judged as if it had had it (its deadline's tenfold, at least a
// second).
[[nodiscard]] inline Nanos max_cpu_wait(Nanos deadline) {
  return std::max<Nanos>(10 * deadline, std::chrono::seconds{1});
}

// One wait for an answer that may go on past its deadline (`deadline_at`; the wait began at `began`, `length`
// before its first deadline) while the processes that owe it wait for a CPU: until they have had `length` of
// CPU time, are no longer runnable, or max_cpu_wait(length) is over since the wait began (never before
// deadline_at). Their CPU time counts from `ran_at_began`, their CPU time when the wait began, where the
// caller read it then, else from the first look past the deadline (a read at the beginning would cost every
// wait, not only a late one). A stopped process (SIGSTOP) is not runnable and is judged at the deadline; a
// spinning one has the CPU time.
class CpuWait {
 public:
  // How often a wait that goes on past its deadline looks at the processes again.
  static constexpr Nanos kLook{std::chrono::milliseconds{10}};

  CpuWait(Nanos deadline_at, Nanos length, Nanos began, std::optional<Nanos> ran_at_began = std::nullopt)
      : deadline_at_(deadline_at),
        length_(length),
        limit_(std::max(deadline_at, began + max_cpu_wait(length))),
        ran_from_(ran_at_began) {}

  [[nodiscard]] Nanos deadline_at() const { return deadline_at_; }
  // Whether the wait went on past its deadline at least once.
  [[nodiscard]] bool went_on() const { return went_on_; }

  // A wait that goes on: until when, the CPU time they had (counted as above), and whether it is the first
  // time this wait went on (worth a log line).
  struct GoOn {
    Nanos until{0};
    Nanos ran{0};
    bool first = false;
  };

  // At `wall`, past the deadline, with what the scheduler shows now of the processes that owe the answer
  // (nullopt: unknown): whether to wait on, and until when (then look again); nullopt: the verdict is due
  // now.
  [[nodiscard]] std::optional<GoOn> go_on(Nanos wall, std::optional<CpuSight> cpu) {
    if (!cpu || !cpu->runnable || wall >= limit_) return std::nullopt;
    if (!ran_from_) ran_from_ = cpu->ran;
    const Nanos ran = std::max(Nanos{0}, cpu->ran - *ran_from_);
    if (ran > length_) return std::nullopt;
    const bool first = !went_on_;
    went_on_ = true;
    return GoOn{.until = std::min(wall + kLook, limit_), .ran = ran, .first = first};
  }

 private:
  Nanos deadline_at_;
  Nanos length_;
  Nanos limit_;                    // max(deadline_at, began + max_cpu_wait(length))
  std::optional<Nanos> ran_from_;  // their CPU time where the count starts (ran_at_began, or the first look)
  bool went_on_ = false;           // went on past the deadline at least once
};

}  // namespace rejuv::kernel
