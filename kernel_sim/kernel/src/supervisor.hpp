// Boot and supervision (supervisor.cpp) and the real-time plan (realtime.cpp; idl/launch.proto RealtimePlan;
// docs/realtime.md): spawning the services and the plant, the Boot, losing a service, the deadlines, the
// shutdown. Owns the plant's process.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "rejuv/channel/wire.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/process.hpp"
#include "service_runtime.hpp"

namespace rejuv::kernel {

// What a service's process may open (rejuv/sys/landlock.hpp): the libraries, its binary, its own /proc/<pid>; and
// a link's enclave (service_runtime.hpp ServiceConfig::HostLink).
[[nodiscard]] std::vector<sys::LandlockRule> landlock_rules(const ServiceRuntime& s);
// How many times a lost link is started again before the run stops (a link that cannot stay up is a fault).
inline constexpr std::uint64_t kMaxLinkRestarts = 16;

// The boot params of a service: its own launch params, then the graph-wide ones (services/sdk service.hpp).
[[nodiscard]] std::vector<wire::BootParam> build_params(const Kernel::Impl& k, const ServiceRuntime& s);

class Supervisor {
 public:
  explicit Supervisor(Kernel::Impl& kernel) : k(kernel) {}

  [[nodiscard]] Result<void, KernelError> spawn_all();
  [[nodiscard]] Result<void, KernelError> spawn_one(ServiceRuntime& s);
  [[nodiscard]] Result<void, KernelError> spawn_plant();
  void send_boot(ServiceRuntime& s);
  void on_child_exit(ServiceRuntime& s);
  void on_plant_exit();
  // The one place a service is lost (death, hang, protocol fault). With SR a rejuvenated service's loss asks
  // for a rollback (docs/design.md §7); before the graph has booted, without SR, or for a driver-level service the
  // run ends.
  void lose_service(ServiceRuntime& s, std::string reason);
  void kill_hung(ServiceRuntime& s, std::string reason);
  void check_deadlines();
  void shutdown_all();

  void start_realtime_plan();  // run_realtime: the kernel's threads and memory, the plant, the Ready
  void apply_realtime(
      ServiceRuntime& s);  // a service that became Ready (spawned, cold-restarted or restored)
  // run_realtime, every 100 ms: a restored copy refused SCHED_FIFO while still in its cgroup's `images/` leaf
  // (no real-time budget there) gets the plan once the placer has moved it into `live/`; any live service of the
  // plan found not at SCHED_FIFO (refused once settled, or moved off it) is given it again.
  void keep_realtime_plan();
  // run_realtime, at every turn of the loop: a rejuvenated service that has sent the kernel nothing since the last
  // look at it while frames sent to it are unreported is sent a Sync (docs/protocol.md "Idle"); one that has not
  // answered it with an Idle within its deadline is hung (stopped, spinning, blocked) and killed, which rolls back
  // (docs/design.md §7). A service the real-time plan runs at SCHED_FIFO (the control chain) is looked at every
  // kChainLivenessLook and has realtime_chain_hang_deadline; any other every kLivenessLook, with
  // realtime_hang_deadline. Lockstep has the idle deadline for this; in real time nothing else finds a hung
  // service before the next timer rollback, and the vehicle flies on what it last published meanwhile. A service
  // that keeps publishing is never asked: the control chain costs the channel nothing.
  void watch_liveness();

  [[nodiscard]] bool plant_started() const { return plant_started_; }
  [[nodiscard]] std::optional<pid_t> plant_pid() const;  // started and not yet reaped

 private:
  void report_stall();  // no step completed for kStallReportAfter
  Kernel::Impl& k;
  sys::ChildProcess plant_;
  bool plant_started_ = false;
  bool realtime_active = false;  // the plan is on and the kernel was granted SCHED_FIFO
  std::vector<std::pair<ServiceId, pid_t>> realtime_pending_;
  std::vector<bool> fifo_refusal_said_;  // apply_realtime: a service refused SCHED_FIFO, said once until given
  std::vector<pid_t> fifo_pid_;          // per service: the process apply_realtime put at SCHED_FIFO (0: none)
  [[nodiscard]] bool runs_fifo(const ServiceRuntime& s) const;
  Nanos liveness_looked_at_{Nanos::min()};  // watch_liveness's last pass
  // watch_liveness, per service (indexed by ServiceId): the incarnation looked at, its frame count then, and the
  // Sync in flight to it (when it went, the frame count its Idle must reach).
  struct LivenessProbe {
    pid_t pid = 0;
    std::uint64_t frames_in = 0;
    std::optional<Nanos> asked_at{};
    std::uint64_t owed = 0;
    Nanos looked_at{};  // the last look
  };
  std::vector<LivenessProbe> probes_;
};

}  // namespace rejuv::kernel
