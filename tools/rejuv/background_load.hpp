// A background load the user names (`rejuv faults --load cpu:N`): N worker processes that
// each do what a companion computer's workload does to the flight computer's CPUs and memory — a working set of
// 64 MiB written, read back and copied around (a vision or mapping pipeline's frames), with allocations freed
// and made again — without ever sleeping, at SCHED_OTHER. They are this process's children: stopped
// (SIGKILL and reaped) when the BackgroundLoad is destroyed, and each dies with this process
// (PR_SET_PDEATHSIG) if it is killed first, so none outlives the command on any exit path.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::cli {

struct LoadSpec {
  unsigned cpu_workers = 0;            // processes, each busy all the time
  std::size_t working_set_mib = 64;    // memory each one keeps touching
  [[nodiscard]] std::string to_string() const;  // "cpu:N"
};

// "cpu:N" (N = 1…64); the error names --load.
[[nodiscard]] Result<LoadSpec, std::string> parse_load(std::string_view text);

class BackgroundLoad {
 public:
  // Forks the workers (from a single-threaded process: sys::fork_worker). An error kills those already started.
  [[nodiscard]] static Result<BackgroundLoad, std::string> start(const LoadSpec& spec);
  BackgroundLoad(BackgroundLoad&&) noexcept = default;
  BackgroundLoad& operator=(BackgroundLoad&&) noexcept = default;
  BackgroundLoad(const BackgroundLoad&) = delete;
  BackgroundLoad& operator=(const BackgroundLoad&) = delete;
  ~BackgroundLoad() { stop(); }

  [[nodiscard]] std::vector<pid_t> pids() const;
  // Workers that have ended by themselves so far (the load was then not there throughout).
  [[nodiscard]] std::size_t ended();
  // SIGKILL and reap every worker. Idempotent.
  void stop() noexcept;

 private:
  explicit BackgroundLoad(std::vector<sys::ChildProcess> workers) : workers_(std::move(workers)) {}
  std::vector<sys::ChildProcess> workers_;
};

}  // namespace rejuv::cli
