// A cgroup per service (DESIGN §7 "A cgroup per service"): every process a service makes — its live
// incarnation, its images and spares, and whatever a compromised incarnation forks — is in it from before
// exec, so the group is bounded as a whole (pids, memory, CPU) and can be ended in one call (cgroup.kill).
//
// Where the controllers are depends on the machine: a pure cgroup v2 host has them in the unified hierarchy; a
// host that keeps the v1 controllers (this project's VMs: pids, memory and cpu are v1, the v2 hierarchy has
// none) has a v2 hierarchy only for cgroup.kill and membership. ServiceCgroup makes the service's group in every
// hierarchy that can carry one of its limits and says, in words, what it applied and what it could not (a
// kernel without root usually cannot make cgroups at all: then the rlimits and the sweeps are what holds).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// What a service's processes may use together.
struct CgroupLimits {
  std::optional<std::uint64_t> pids{};          // pids.max: processes and threads
  std::optional<std::uint64_t> memory_bytes{};  // memory.max (v2) or memory.limit_in_bytes (v1)
  std::optional<std::uint32_t> cpu_percent{};   // cpu.max (v2) or cfs quota (v1): percent of one CPU
  // cpu.rt_runtime_us per second (v1, where the kernel groups real-time tasks, CONFIG_RT_GROUP_SCHED): what
  // its SCHED_FIFO tasks may run each second; without it none of them may be SCHED_FIFO at all. The
  // kernel's directory gets the sum over its services.
  std::optional<std::uint64_t> rt_runtime_us{};
};

class ServiceCgroup {
 public:
  ServiceCgroup() = default;
  ServiceCgroup(const ServiceCgroup&) = delete;
  ServiceCgroup& operator=(const ServiceCgroup&) = delete;
  ServiceCgroup(ServiceCgroup&& other) noexcept = default;
  ServiceCgroup& operator=(ServiceCgroup&& other) noexcept;
  ~ServiceCgroup() { remove(); }

  // Makes `<own cgroup>/rejuv-<this pid>-<scope>/<name>` in each hierarchy that can hold a limit or kill it,
  // and applies `limits`; `scope` tells apart the kernels of one process (their services share names). An
  // error only when no hierarchy could be used at all (no cgroup file system, no right to make one); a limit
  // that could not be applied is named in description().
  [[nodiscard]] static SysResult<ServiceCgroup> create(std::string_view scope, const std::string& name,
                                                       const CgroupLimits& limits);

  // The cgroup.procs files, open for writing: a spawned child writes "0" to each before exec (async-signal-
  // safe), so that it and everything it makes are in the group from its first instruction.
  [[nodiscard]] std::span<const int> join_fds() const { return join_fds_; }

  // Every process of the group killed in one call (cgroup.kill, v2); where no v2 hierarchy could be used,
  // each process listed in cgroup.procs is sent SIGKILL. Reaping is the caller's (the processes are its
  // children).
  void kill_all() const;
  // The pids in the group (read from cgroup.procs of the first hierarchy).
  [[nodiscard]] std::vector<pid_t> members() const;

  // "cgroup v2 (kill), pids.max 64 (v1 pids), memory 1024 MiB (v1 memory), cpu 50 % (v1 cpu)" and what failed.
  [[nodiscard]] const std::string& description() const { return description_; }
  [[nodiscard]] bool valid() const { return !dirs_.empty(); }

 private:
  // Kills what is left, waits briefly for it to leave, and removes the directories (then their parent, if
  // this was the last service's).
  void remove() noexcept;

  std::vector<std::filesystem::path> dirs_{};  // one per hierarchy used
  std::optional<std::filesystem::path> unified_{};  // the v2 one (cgroup.kill)
  std::vector<UniqueFd> join_{};
  std::vector<int> join_fds_{};
  std::string description_{};
};

}  // namespace rejuv::sys
