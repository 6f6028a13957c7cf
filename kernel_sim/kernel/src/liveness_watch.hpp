// Who is hung in real time (docs/protocol.md "Idle", docs/design.md §7 "Faults"): the Supervisor's liveness watch,
// as a part that owns its state and reads no clock (the Supervisor hands it the wall time and what it sees of each
// service; tests/unit/kernel/liveness_watch_test.cpp).
//
// A watched service (rejuvenated, live, Ready, not replaying the catch-up) that has sent the kernel nothing since
// the last look while frames sent to it are unreported is asked for an Idle (a Sync); one that has not answered
// within its deadline is hung (stopped, spinning, blocked) and killed, which rolls back. A service the real-time
// plan runs at SCHED_FIFO (the control chain) is looked at every kChainLook with the chain's deadline, any other
// every kLook with the others'. A service that keeps publishing is never asked: the control chain costs the
// channel nothing. A service still runnable when its deadline is over is judged by the CPU time it had since the
// Sync instead: waiting for a CPU (a loaded machine, a stalled virtual CPU, a higher real-time priority) is the
// machine's doing, not the service's, and is not held against it (spared_for_cpu) — for at most max_cpu_wait.
// One that is stopped, blocked or asleep with the Sync unanswered is judged by the deadline as it is. Lockstep
// has the step's idle deadline for this; in real time nothing else finds a hung service before the next timer
// rollback, and the vehicle flies on what it last published meanwhile.
#pragma once

#include <sys/types.h>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <vector>

#include "cpu_wait.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::kernel {

// What the watch sees of one service at a look.
struct LivenessSight {
  ServiceId id;
  bool watched = false;  // rejuvenated, live, Ready, not lost, not replaying the catch-up
  bool chain = false;    // the real-time plan runs it at SCHED_FIFO
  pid_t pid = 0;         // its live incarnation
  std::uint64_t frames_in = 0;   // frames it sent the kernel
  std::uint64_t frames_out = 0;  // frames the kernel sent it
  std::uint64_t reported = 0;    // of those, reported handled (its Idles)
};

// What the Supervisor does about a service after a look.
struct LivenessCall {
  enum class Kind : std::uint8_t {
    Nothing,  // not due, alive, or its deadline not over
    Ask,      // send it a Sync; asked() once it went, with `owed`
    Overdue,  // no Idle within `deadline` of the Sync: hung unless its channel holds an Idle reporting `owed`
  };
  Kind kind = Kind::Nothing;
  std::uint64_t owed = 0;  // Ask: the frames its Idle must report; Overdue: those it was asked to report
  Nanos deadline{0};       // Overdue: the deadline it missed
};

class LivenessWatch {
 public:
  static constexpr Nanos kChainLook{std::chrono::milliseconds{10}};  // the chain publishes every control period
  static constexpr Nanos kLook{std::chrono::milliseconds{100}};

  LivenessWatch(Nanos chain_deadline, Nanos other_deadline)
      : chain_deadline_(chain_deadline), other_deadline_(other_deadline) {}

  // Whether a pass over the services is due at `wall` (at most one per kChainLook); the pass begins if so.
  [[nodiscard]] bool begin_pass(Nanos wall) {
    if (last_pass_ && wall - *last_pass_ < kChainLook) return false;
    last_pass_ = wall;
    return true;
  }

  // One service in the pass at `wall`.
  [[nodiscard]] LivenessCall look(const LivenessSight& s, Nanos wall) {
    Probe& probe = probe_of(s.id);
    if (wall - probe.looked_at < (s.chain ? kChainLook : kLook)) return {};
    if (!s.watched || probe.pid != s.pid || probe.frames_in != s.frames_in) {
      fresh(s, wall);  // gone, a new incarnation, or it spoke since the last look: alive
      return {};
    }
    probe.looked_at = wall;
    if (!probe.asked_at) {
      if (s.reported < s.frames_out) return {.kind = LivenessCall::Kind::Ask, .owed = s.frames_out, .deadline = {}};
      return {};
    }
    const Nanos deadline = s.chain ? chain_deadline_ : other_deadline_;
    if (wall - *probe.asked_at <= deadline) return {};
    return {.kind = LivenessCall::Kind::Overdue, .owed = probe.owed, .deadline = deadline};
  }

  // The Sync asked for went to `id` at `wall`: its Idle must report `owed` frames. `cpu`: what the scheduler had
  // given its live incarnation until then, nullopt when unknown.
  void asked(ServiceId id, Nanos wall, std::uint64_t owed, std::optional<CpuSight> cpu = std::nullopt) {
    Probe& probe = probe_of(id);
    probe.asked_at = wall;
    probe.owed = owed;
    probe.ran_at_ask = cpu ? std::optional<Nanos>{cpu->ran} : std::nullopt;
    probe.cpu_wait.reset();
  }

  // A service spared for waiting for a CPU: the CPU time it had since the Sync, the time since the Sync, and
  // whether this is the first time for this Sync (worth a log line).
  struct Spared {
    Nanos ran{0};
    Nanos since{0};
    bool first = false;
  };

  // After an Overdue whose Idle is not in the channel: whether the service is spared because it is runnable and
  // has had less than its deadline of CPU time since the Sync (CpuWait, from the CPU time it had when the
  // Sync went). `cpu`: what the scheduler gives it now, nullopt when unknown. Never spared once max_cpu_wait
  // is over since the Sync; nullopt (hung) otherwise. A service that spins has the CPU time; one stopped or
  // asleep by its own call is not runnable (sys::TaskCpu).
  [[nodiscard]] std::optional<Spared> spared_for_cpu(ServiceId id, Nanos wall, std::optional<CpuSight> cpu,
                                                     Nanos deadline) {
    Probe& probe = probe_of(id);
    if (!probe.asked_at || !probe.ran_at_ask) return std::nullopt;
    if (!probe.cpu_wait) {
      probe.cpu_wait.emplace(*probe.asked_at + deadline, deadline, *probe.asked_at, probe.ran_at_ask);
    }
    const std::optional<CpuWait::GoOn> on = probe.cpu_wait->go_on(wall, cpu);
    if (!on) return std::nullopt;
    return Spared{.ran = on->ran, .since = wall - *probe.asked_at, .first = on->first};
  }

  // After an Overdue (killed, or its Idle was in the channel): looked at afresh from what it is now.
  void fresh(const LivenessSight& s, Nanos wall) {
    probe_of(s.id) = Probe{.pid = s.pid, .frames_in = s.frames_in, .asked_at = std::nullopt, .owed = 0,
                           .ran_at_ask = std::nullopt, .cpu_wait = std::nullopt, .looked_at = wall};
  }

 private:
  // Per service: the incarnation looked at, its frame count then, and the Sync in flight to it (when it went, the
  // frame count its Idle must reach).
  struct Probe {
    pid_t pid = 0;
    std::uint64_t frames_in = 0;
    std::optional<Nanos> asked_at{};
    std::uint64_t owed = 0;
    std::optional<Nanos> ran_at_ask{};  // its CPU time when the Sync went (sys::task_cpu)
    std::optional<CpuWait> cpu_wait{};  // its wait past the deadline for want of a CPU, once Overdue
    Nanos looked_at{Nanos::min() / 2};  // never looked at: due at once
  };
  Probe& probe_of(ServiceId id) {
    if (id.value() >= probes_.size()) probes_.resize(id.value() + 1);
    return probes_[id.value()];
  }

  Nanos chain_deadline_;
  Nanos other_deadline_;
  std::optional<Nanos> last_pass_;
  std::vector<Probe> probes_;  // by ServiceId
};

}  // namespace rejuv::kernel
