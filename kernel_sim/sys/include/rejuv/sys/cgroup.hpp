// A cgroup per service (docs/design.md §7 "A cgroup per service"): every process a service makes — its live
// incarnation, its images and spares, and whatever a compromised incarnation forks — is in it from before
// exec, so the group is bounded as a whole (pids, memory, CPU) and can be ended in one call (cgroup.kill).
//
// Where the controllers are depends on the machine: a pure cgroup v2 host has them in the unified hierarchy; a
// host that keeps the v1 controllers (this project's VMs: pids, memory and cpu are v1, the v2 hierarchy has
// none) has a v2 hierarchy only for cgroup.kill and membership. ServiceCgroup makes the service's group in every
// hierarchy that can carry one of its limits and says, in words, what it applied and what it could not (a
// kernel without root usually cannot make cgroups at all: then the rlimits and the sweeps are what holds).
//
// Each service's group has two leaves (docs/sandbox.md "A cgroup per service"): `live/`, where a spawned
// incarnation starts and where everything it forks is born (strays), bounded by the memory limit and ended in
// one call (cgroup.kill); and `images/`, where the kernel moves each frozen image once it knows its pid, so
// that neither the memory cgroup's OOM killer (which picks only among the processes of the cgroup that is out
// of memory) nor a kill of the live leaf ever reaches an image. Limits on processes and CPU stay on the
// service's directory above both leaves: they bound the service as a whole.
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

// The two leaves of a service's group.
enum class CgroupLeaf : std::uint8_t { Live, Images };

// One move of a process into a leaf, prepared on the kernel's thread (the leaf's cgroup.procs files
// duplicated, so that it outlives the group it names) and carried out anywhere: a move waits for an RCU grace
// period when no move happened for a while (milliseconds), which the kernel does not pay on its loop.
class CgroupMove {
 public:
  CgroupMove() = default;
  CgroupMove(std::vector<UniqueFd> procs, pid_t pid) : procs_(std::move(procs)), pid_(pid) {}
  // Writes the pid into each hierarchy's cgroup.procs; the first error (ESRCH: the process is gone).
  [[nodiscard]] SysResult<void> run() const;
  [[nodiscard]] pid_t pid() const { return pid_; }

 private:
  std::vector<UniqueFd> procs_{};
  pid_t pid_ = 0;
};

class ServiceCgroup {
 public:
  ServiceCgroup() = default;
  ServiceCgroup(const ServiceCgroup&) = delete;
  ServiceCgroup& operator=(const ServiceCgroup&) = delete;
  ServiceCgroup(ServiceCgroup&& other) noexcept = default;
  ServiceCgroup& operator=(ServiceCgroup&& other) noexcept;
  ~ServiceCgroup() { remove(); }

  // Makes `<own cgroup>/rejuv-<this pid>-<scope>/<name>/{live,images}` in each hierarchy that can hold a limit or kill it,
  // and applies `limits`; `scope` tells apart the kernels of one process (their services share names). An
  // error only when no hierarchy could be used at all (no cgroup file system, no right to make one); a limit
  // that could not be applied is named in description().
  [[nodiscard]] static SysResult<ServiceCgroup> create(std::string_view scope, const std::string& name,
                                                       const CgroupLimits& limits);

  // The live leaf's cgroup.procs files, open for writing: a spawned child writes "0" to each before exec
  // (async-signal-safe), so that it and everything it makes are in the live leaf from its first instruction.
  [[nodiscard]] std::span<const int> join_fds() const { return join_fds_; }

  // `pid` into `leaf` in every hierarchy, now (a write per hierarchy; see CgroupMove for its cost).
  [[nodiscard]] SysResult<void> move(pid_t pid, CgroupLeaf leaf) const;
  // The same move, to be run later or on another thread (duplicates the leaf's fds).
  [[nodiscard]] SysResult<CgroupMove> prepare_move(pid_t pid, CgroupLeaf leaf) const;

  // Every process of the live leaf — the live incarnation and whatever it forked — killed in one call
  // (cgroup.kill of the v2 leaf). False, and nothing done, where no v2 hierarchy could be used: the caller
  // then ends them one by one as it would without cgroups.
  [[nodiscard]] bool kill_live() const;
  // Whether `pid` is in `leaf` of the v2 hierarchy (/proc/<pid>/cgroup); false where there is none.
  [[nodiscard]] bool in_leaf(pid_t pid, CgroupLeaf leaf) const;
  // Whether `pid` is in `leaf` of every hierarchy the group uses. A move writes the hierarchies one after the
  // other (the v2 one first), each write possibly waiting milliseconds: between them a process is in the v2
  // live leaf while a v1 cpu hierarchy still holds it in `images/`, whose real-time budget is 0 (SCHED_FIFO
  // refused there). False where the group has no hierarchy.
  [[nodiscard]] bool settled_in(pid_t pid, CgroupLeaf leaf) const;
  // Every process of the group killed in one call (cgroup.kill, v2); where no v2 hierarchy could be used,
  // each process listed in either leaf's cgroup.procs is sent SIGKILL. Reaping is the caller's (the processes
  // are its children).
  void kill_all() const;
  // The pids in the group, or in one leaf (read from cgroup.procs of the first hierarchy).
  [[nodiscard]] std::vector<pid_t> members() const;
  [[nodiscard]] std::vector<pid_t> members(CgroupLeaf leaf) const;
  // How many processes the OOM killer has killed in the live leaf since it was made (v1 memory.oom_control or
  // v2 memory.events "oom_kill"); nullopt where no memory controller bounds it.
  [[nodiscard]] std::optional<std::uint64_t> live_oom_kills() const;
  // Whether a memory controller bounds the group (its limit applied, its OOM kills readable).
  [[nodiscard]] bool bounds_memory() const { return oom_events_.has_value(); }
  // Whether a real-time budget was asked for (CgroupLimits::rt_runtime_us) and refused: v1 RT groups share the
  // machine's budget, and other groups held the rest of it. Its tasks are then refused SCHED_FIFO.
  [[nodiscard]] bool rt_budget_refused() const { return rt_budget_refused_; }

  // "cgroup v2 (kill), pids.max 64 (v1 pids), memory 1024 MiB (v1 memory), cpu 50 % (v1 cpu)" and what failed.
  [[nodiscard]] const std::string& description() const { return description_; }
  [[nodiscard]] bool valid() const { return !dirs_.empty(); }
  // The service's directory in the v2 hierarchy (its cgroup.freeze freezes the whole group); none without one.
  [[nodiscard]] const std::optional<std::filesystem::path>& unified_dir() const { return unified_; }

 private:
  // Kills what is left, waits briefly for it to leave, returns its real-time budget (v1 cpu) and removes the
  // directories (then their parent, if this was the last service's).
  void remove() noexcept;

  [[nodiscard]] std::span<const int> procs_fds(CgroupLeaf leaf) const {
    return leaf == CgroupLeaf::Live ? join_fds_ : images_fds_;
  }

  std::vector<std::filesystem::path> dirs_{};  // the service's directory, one per hierarchy used
  // The same as /proc/<pid>/cgroup names them, in the order of dirs_: a controller the hierarchy carries ("" for
  // v2) and the path (one path may be in several hierarchies).
  std::vector<std::pair<std::string, std::string>> names_{};
  std::optional<std::filesystem::path> unified_{};  // the v2 one (cgroup.kill)
  std::optional<std::filesystem::path> oom_events_{};  // the live leaf's memory.oom_control (v1) or memory.events
  std::vector<UniqueFd> join_{};  // live/cgroup.procs, one per hierarchy
  std::vector<int> join_fds_{};
  std::vector<UniqueFd> images_{};  // images/cgroup.procs, one per hierarchy
  std::vector<int> images_fds_{};
  std::string description_{};
  bool rt_budget_refused_ = false;
};

}  // namespace rejuv::sys
