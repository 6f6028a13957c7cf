// Warden (warden.cpp, docs/design.md §7 "Protection"): the calls the seccomp filter refers to the kernel, the
// services' output, the strays of a service's session and the violations counted. Owns the sweep's schedule.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "cgroup_placer.hpp"
#include "image_coordinator.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/landlock.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/seccomp.hpp"
#include "service_runtime.hpp"

namespace rejuv::kernel {

enum class Violation : std::uint8_t { ForbiddenCall, StrayProcess, ImageLost, OutOfMemory };

class Warden {
 public:
  explicit Warden(Kernel::Impl& kernel) : k(kernel) {}

  // Calls the filter referred to the kernel: boot calls continue while the service boots; anything else
  // kills the caller and counts a violation.
  void on_seccomp_notice(ServiceRuntime& s);
  // Lines the service wrote on fds 1-2, logged under its name (rate-limited, control characters escaped).
  void on_service_output(ServiceRuntime& s, bool final = false);
  // Kills every process of a service's session that is neither its live incarnation nor an image the kernel
  // knows (strays): at every commit, after every rollback, about once a simulated second, and at shutdown.
  // Deferred while copies the kernel asked for are on their way (their pids are not known yet).
  // After a rollback it first waits (briefly, off the critical path) for copies asked for earlier, so that no
  // stray outlives the rollback (ForCopies); elsewhere a service with a copy on its way is swept next time.
  void sweep_strays(std::string_view when, bool final = false, SweepWait wait = SweepWait::No);
  void sweep_if_due();  // at a safe point off the critical paths: a sweep asked for, or a simulated second
                        // since the last
  void record_violation(ServiceRuntime& s, Violation kind, std::string_view what);
  void close_sandbox(ServiceRuntime& s);  // listener and output pipe, out of epoll
  void join_cgroup(ServiceRuntime& s);    // makes the service's cgroup at its first spawn (or notes why not)
  // The cgroup leaves (docs/sandbox.md "A cgroup per service"). Every image and spare the kernel knows moved
  // to its service's `images/` leaf (each once; off the loop, CgroupPlacer): at every sweep, and before a
  // rollback kills the live leaves.
  void place_images();
  // No cgroup move queued or running (each holds the cgroup.procs fds it writes to until it is done).
  [[nodiscard]] bool placements_idle() const { return placer.idle(); }
  void place_live(const ServiceRuntime& s);  // a restored incarnation into `live/`
  // Whether a child of the kernel is one it knows: the plant, a live service, an image of a kept or retiring
  // generation, a process the reaper is ending. Any other child is a stray, or a spare whose pid is not
  // reported yet.
  [[nodiscard]] bool known_child(pid_t pid) const;
  // At a rollback: the live leaf — the incarnation and everything it forked — killed in one call
  // (cgroup.kill), if every image and spare of the service the kernel knows is in `images/` (a move still
  // running, or a copy born in `live/` and not moved yet, would die with it). False, and nothing killed,
  // otherwise or where the group has no cgroup.kill: the caller then ends the incarnation as without
  // cgroups (stopped now, its strays swept after the rollback). Never waits.
  [[nodiscard]] bool kill_live_leaf(const ServiceRuntime& s);
  // Whether the OOM killer killed processes of the service's live leaf since the last look: counted as an
  // out-of-memory violation (the live incarnation's loss_reason set when `live_killed`). True if it did.
  bool count_out_of_memory(ServiceRuntime& s, bool live_killed);
  // A restored incarnation's new stdout/stderr pipe: what the old one still holds is logged, then it is
  // closed and the new one watched.
  [[nodiscard]] sys::SysResult<void> replace_output(ServiceRuntime& s, sys::UniqueFd read_end);
  [[nodiscard]] sys::ResourceLimits limits_for(const ServiceRuntime& s) const;

 private:
  // The longest path the kernel reads from a booting service's open (PATH_MAX).
  static constexpr std::size_t kMaxBootPath = 4096;
  // Whether an open while booting names a path within the service's Landlock rules; `shown` the path if not.
  [[nodiscard]] static bool boot_open_within_reach(const ServiceRuntime& s, const sys::SeccompNotice& notice,
                                                   std::string& shown);

  Kernel::Impl& k;
  CgroupPlacer placer;
  std::vector<pid_t> placed_images;  // moved (or asked to be) to their `images/` leaf
  std::vector<std::pair<ServiceId, pid_t>> killed_with_leaf;  // strays a rollback's cgroup.kill ended: counted
                                                              // by the next sweep
  std::optional<std::string_view> sweep_due;  // why a sweep is wanted
  Nanos last_sweep{0};                        // kernel clock
};

}  // namespace rejuv::kernel
