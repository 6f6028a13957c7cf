// The worker pool of the commands that fly missions side by side (`rejuv faults --jobs`, `rejuv sweep --runner
// run --jobs`). A pool has N worker slots; each holds one DDS domain for the pool's life (one rule for every
// command: `--domain D` gives slot j the domain D + j, else each slot leases a free one, sys/lease.hpp, so that
// two commands, or a command and the test suite, never share a domain) and one CPU (slot j: CPU j mod the
// CPUs online). Tasks are started in free slots in order, each as one child process; the pool reports each
// ending task, and on SIGINT/SIGTERM (the caller's signalfd) starts no more, sends SIGTERM to the running ones
// and kills those still running after a grace period. Every worker is a sys::ChildProcess: on any early
// return it is killed and reaped, so no process outlives the pool.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/lease.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::cli {

// Where a task's process runs: its DDS domain and CPU.
struct WorkerSlot {
  std::uint32_t index = 0;
  std::uint32_t dds_domain = 0;
  int cpu = 0;
};

struct PoolConfig {
  unsigned workers = 1;
  std::optional<std::uint32_t> first_domain{};  // --domain: slot j uses first_domain + j; unset: leased
  const sys::SignalFd* signals = nullptr;       // SIGINT, SIGTERM: interrupt the pool (none: not interruptible)
  std::chrono::seconds grace{20};               // after SIGTERM, how long a worker may take to stop
  std::chrono::milliseconds poll{100};          // how often the pool looks at its workers
};

// A task's worker that ended (not reported once the pool was interrupted).
struct TaskEnd {
  std::size_t task = 0;
  WorkerSlot slot{};
  sys::ExitStatus status{};
  std::chrono::duration<double> wall{};
};

enum class PoolOutcome : std::uint8_t { Done, Interrupted };

// Starts task `task`'s process in `slot`.
using StartTask = std::function<Result<sys::ChildProcess, std::string>(std::size_t task, const WorkerSlot& slot)>;

struct PoolHooks {
  // In this process, as each task's process ends; an error stops the pool (and is its error).
  std::function<Result<void, std::string>(const TaskEnd&)> ended{};
  std::function<void()> tick{};                 // every poll (e.g. a progress bar redrawn)
};

class JobPool {
 public:
  // Takes the slots' domains (the lease's error, when no domain is free, as text).
  [[nodiscard]] static Result<JobPool, std::string> create(const PoolConfig& config);

  // Runs tasks 0..count-1 (each started by `start` in a free slot) until all have ended or the pool is
  // interrupted. An error (a task that cannot start, a wait that fails) kills and reaps every worker first.
  [[nodiscard]] Result<PoolOutcome, std::string> run(std::size_t count, const StartTask& start,
                                                     const PoolHooks& hooks = {});

  [[nodiscard]] const std::vector<WorkerSlot>& slots() const { return slots_; }

 private:
  JobPool(PoolConfig config, std::vector<sys::DdsDomainLease> leases, std::vector<WorkerSlot> slots)
      : config_(config), leases_(std::move(leases)), slots_(std::move(slots)) {}
  PoolConfig config_;
  std::vector<sys::DdsDomainLease> leases_;  // held while the pool lives
  std::vector<WorkerSlot> slots_;
};

// The usual task process: `body(task, slot)` in a process forked from this one through sys::fork_worker
// (it dies with this process), exiting with what the body returns. Fork only while single-threaded.
[[nodiscard]] StartTask forked(std::function<int(std::size_t task, const WorkerSlot& slot)> body);

}  // namespace rejuv::cli
