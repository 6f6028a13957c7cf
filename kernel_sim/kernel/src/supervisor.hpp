// Boot and supervision (supervisor.cpp) and the real-time plan (realtime.cpp; idl/launch.proto RealtimePlan;
// docs/realtime.md): spawning the services and the plant, the Boot, losing a service, the deadlines, the
// shutdown. Owns the plant's process.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cpu_wait.hpp"
#include "liveness_watch.hpp"
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
  explicit Supervisor(Kernel::Impl& kernel);

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
  // run_realtime, at every turn of the loop: the liveness watch's pass (liveness_watch.hpp) — a rejuvenated
  // service silent since the last look while frames sent to it are unreported is sent a Sync; one without an Idle
  // within its deadline (KernelOptions::realtime_chain_hang_deadline at SCHED_FIFO, realtime_hang_deadline
  // otherwise) is killed as hung, which rolls back (docs/design.md §7).
  void watch_liveness();

  // Lockstep: when the loop next looks at the active step's idle deadline (`deadline`): the deadline itself,
  // or later while a service late at it waits for a CPU (check_deadlines).
  [[nodiscard]] Nanos idle_look(Nanos deadline) const {
    return idle_look_ && *idle_look_ > deadline ? *idle_look_ : deadline;
  }

  [[nodiscard]] bool plant_started() const { return plant_started_; }
  [[nodiscard]] std::optional<pid_t> plant_pid() const;  // started and not yet reaped

 private:
  void report_stall();  // no step completed for kStallReportAfter
  // Lockstep: whether `s`, late at the step's idle deadline (`deadline_at`), waits for a CPU (CpuWait:
  // runnable, with less than the deadline's length of CPU time since it was first seen late, up to
  // max_cpu_wait); then looked at again a CpuWait::kLook later. `cpu`: what the scheduler showed of it before
  // its channel was read.
  [[nodiscard]] bool spared_at_idle_deadline(const ServiceRuntime& s, Nanos deadline_at, Nanos t,
                                             std::optional<CpuSight> cpu);
  Kernel::Impl& k;
  sys::ChildProcess plant_;
  bool plant_started_ = false;
  bool realtime_active = false;  // the plan is on and the kernel was granted SCHED_FIFO
  std::vector<std::pair<ServiceId, pid_t>> realtime_pending_;
  std::vector<bool> fifo_refusal_said_;  // apply_realtime: a service refused SCHED_FIFO, said once until given
  std::vector<pid_t> fifo_pid_;          // per service: the process apply_realtime put at SCHED_FIFO (0: none)
  [[nodiscard]] bool runs_fifo(const ServiceRuntime& s) const;
  [[nodiscard]] LivenessSight liveness_sight(const ServiceRuntime& s) const;
  LivenessWatch liveness_;
  std::vector<std::optional<CpuWait>> idle_waits_;  // by ServiceId: its wait past the step's idle deadline
  std::optional<Nanos> idle_look_;                  // the next look while one waits for a CPU (wall clock)
};

}  // namespace rejuv::kernel
