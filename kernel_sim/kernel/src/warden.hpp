// Warden (warden.cpp, docs/design.md §7 "Protection"): the calls the seccomp filter refers to the kernel, the
// services' output, the strays of a service's session and the violations counted. Owns the sweep's schedule.
// It knows the kernel only through what it is handed (WardenParts, WardenPeers) and is built and tested alone
// (tests/unit/kernel/warden_test.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cgroup_placer.hpp"
#include "image_coordinator.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/landlock.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/seccomp.hpp"
#include "service_runtime.hpp"

namespace rejuv::kernel {

enum class Violation : std::uint8_t { ForbiddenCall, StrayProcess, ImageLost, OutOfMemory };

// The kernel's parts the Warden reads (the graph, the options, the clock mode: fixed once the kernel is made)
// and the ones it changes: the services' containment and counters, and the epoll set (their output pipes).
struct WardenParts {
  const proto::Launch& graph;
  const KernelOptions& options;
  const ClockMode& clock_mode;
  std::vector<ServiceRuntime>& services;  // by ServiceId
  const sys::Epoll& epoll;
};

// What the Warden asks of the other owners and tells them: the kernel's time, mode and log, the Router's
// security-event topic, the Rejuvenator's rollback and images. Kernel::Impl answers from its owners (impl.hpp
// KernelWardenPeers); a test answers from its own state.
class WardenPeers {
 public:
  WardenPeers() = default;
  WardenPeers(const WardenPeers&) = delete;
  WardenPeers& operator=(const WardenPeers&) = delete;
  WardenPeers(WardenPeers&&) = delete;
  WardenPeers& operator=(WardenPeers&&) = delete;
  virtual ~WardenPeers() = default;

  [[nodiscard]] virtual Nanos now() const = 0;   // the kernel clock
  [[nodiscard]] virtual Nanos wall() const = 0;  // CLOCK_MONOTONIC
  [[nodiscard]] virtual SrMode mode() const = 0;
  // Whether a violation in MC rolls back at once: SR is on and the kernel is not shutting down.
  [[nodiscard]] virtual bool rolls_back_on_violation() const = 0;
  virtual void log(const std::string& line) = 0;                           // the kernel's log
  virtual void service_log(ServiceRuntime& s, std::string_view line) = 0;  // under the service's name
  virtual void publish_security_event(ServiceId s, std::uint32_t detail,
                                      rejuv_msg_SecurityEventKind kind) = 0;
  virtual void request_rollback(std::string reason) = 0;

  // The images (the Rejuvenator's): every image of the kept and the retiring generations.
  virtual void for_each_image(const std::function<void(const image::Image&)>& f) const = 0;
  // The plant, a live service, a copy of a kept or retiring generation, or a process the reaper is ending.
  [[nodiscard]] virtual bool knows_child(pid_t pid) const = 0;
  // The copies' answers that arrived read, and the retiring generations let go of where none is awaited.
  virtual void settle_images() = 0;
  [[nodiscard]] virtual bool checkpoint_running() const = 0;
  // An image owed to an abandoned checkpoint (its Taken not read yet), until the next commit.
  [[nodiscard]] virtual bool owes_image(ServiceId s) const = 0;
  // One copy of `s` the kernel asked for and let go of unheard taken off the count (image::UnheardCopies).
  [[nodiscard]] virtual bool take_unheard_copy(ServiceId s) = 0;
  virtual void kill_and_reap_later(sys::ChildProcess p) = 0;  // killed now, reaped off the critical path
};

class Warden {
 public:
  Warden(WardenParts parts, WardenPeers& peers) : parts_(parts), peers_(peers) {}

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

  // The images the kernel holds, each copy with its service; whether a copy of `service` is on its way.
  template <class F>
  void for_each_copy(std::optional<ServiceId> service, F f) const;
  [[nodiscard]] bool copies_pending(ServiceId service) const;
  // Per service, whether a copy the kernel asked for is on its way (sweep_strays).
  [[nodiscard]] std::vector<bool> copies_on_their_way(bool final, SweepWait wait);
  void say(const char* format, ...) __attribute__((format(printf, 2, 3)));

  WardenParts parts_;
  WardenPeers& peers_;
  CgroupPlacer placer;
  std::vector<pid_t> placed_images;  // moved (or asked to be) to their `images/` leaf
  std::vector<std::pair<ServiceId, pid_t>> killed_with_leaf;  // strays a rollback's cgroup.kill ended: counted
                                                              // by the next sweep
  std::optional<std::string_view> sweep_due;  // why a sweep is wanted
  Nanos last_sweep{0};                        // kernel clock
};

}  // namespace rejuv::kernel
