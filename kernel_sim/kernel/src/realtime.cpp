// The real-time plan of a REALTIME run (idl/launch.proto RealtimePlan; docs/realtime.md): the
// plant (the world) and the kernel at SCHED_FIFO above the control chain's services, each at its launch
// rt_priority; every one with SCHED_RESET_ON_FORK, so that what a service makes — an image, a spare, a stray,
// a thread — runs SCHED_OTHER, never above the live chain; RLIMIT_RTTIME on each service, so that one
// spinning at SCHED_FIFO is killed by the OS (and, lost, rolled back) instead of holding a CPU. Without the
// privilege the run says once what it could not apply and goes on at SCHED_OTHER. Where the plan names CPUs
// (kernel_cpu, plant_cpu, a service's cpu), each is pinned to its own (sched_setaffinity); a CPU the machine
// lacks is named in the log and ignored.
#include <algorithm>
#include <utility>
#include <vector>

#include "impl.hpp"
#include "rejuv/sys/realtime.hpp"

namespace rejuv::kernel {

void Supervisor::start_realtime_plan() {
  const proto::RealtimePlan& plan = k.graph.graph.realtime();
  if (!plan.enabled() || k.clock_mode != ClockMode::Realtime) return;
  const launch::RealtimeValues v = launch::realtime_values(plan);
  const auto kernel = static_cast<int>(v.kernel_priority);
  const auto plant_priority = static_cast<int>(v.plant_priority);
  if (auto ok = sys::set_fifo_all_threads(kernel); !ok) {
    k.log(
        "real-time plan not applied: the kernel cannot have SCHED_FIFO %d (%s; it needs CAP_SYS_NICE or "
        "RLIMIT_RTPRIO): every process runs SCHED_OTHER",
        kernel, ok.error().to_string().c_str());
    return;
  }
  realtime_active = true;
  std::string notes;
  if (plan.lock_memory()) {
    if (auto ok = sys::lock_all_memory(); !ok) notes += "; memory not locked (" + ok.error().to_string() + ")";
  }
  if (plan.has_kernel_cpu()) {
    if (auto ok = sys::pin_all_threads(plan.kernel_cpu()); !ok) {
      notes += "; the kernel not pinned to CPU " + std::to_string(plan.kernel_cpu()) + " (" + ok.error().to_string() + ")";
    } else {
      notes += "; kernel on CPU " + std::to_string(plan.kernel_cpu());
    }
  }
  if (plant_started_ && plant_priority > 0) {
    if (auto ok = sys::set_fifo(plant_.pid(), plant_priority); !ok) {
      notes += "; the plant stays SCHED_OTHER (" + ok.error().to_string() + ")";
    }
  }
  if (plant_started_ && plan.has_plant_cpu()) {
    if (auto ok = sys::pin_to_cpu(plant_.pid(), plan.plant_cpu()); !ok) {
      notes += "; the plant not pinned to CPU " + std::to_string(plan.plant_cpu()) + " (" + ok.error().to_string() + ")";
    } else {
      notes += "; plant on CPU " + std::to_string(plan.plant_cpu());
    }
  }
  int chain = 0;
  for (ServiceRuntime& s : k.services) {
    if (s.config.spec != nullptr && s.config.spec->has_cpu() && s.live()) {
      if (auto ok = sys::pin_to_cpu(s.proc.process.pid(), s.config.spec->cpu()); !ok) {
        notes += "; '" + s.name + "' not pinned to CPU " + std::to_string(s.config.spec->cpu()) + " (" +
                 ok.error().to_string() + ")";
      }
    }
    if (s.live() && s.proc.phase() == Phase::Ready) apply_realtime(s);
    if (s.config.spec != nullptr && s.config.spec->rt_priority() > 0) ++chain;
  }
  k.log(
      "real-time plan: kernel SCHED_FIFO %d, plant %d, %d services at their rt_priority (RLIMIT_RTTIME %u "
      "ms)%s",
      kernel, plant_priority, chain, v.max_rt_time_ms, notes.c_str());
}

void Supervisor::apply_realtime(ServiceRuntime& s) {
  if (!realtime_active || s.config.spec == nullptr || !s.live()) return;
  const proto::ServiceSpec& spec = *s.config.spec;
  // Its CPU first (a copy inherits its image's, which is the incarnation's it was taken from: set again for
  // whichever process is the live service), then its priority.
  if (spec.has_cpu()) {
    (void)sys::pin_to_cpu(s.proc.process.pid(), spec.cpu());  // a refusal was named once (start_realtime_plan)
  }
  if (spec.rt_priority() == 0) return;
  // RLIMIT_RTTIME was set at spawn (limits_for) and is inherited by every image; the policy is reset on fork
  // and given back here to whichever process is the live service.
  const pid_t pid = s.proc.process.pid();
  auto ok = sys::set_fifo(pid, static_cast<int>(spec.rt_priority()));
  fifo_refusal_said_.resize(k.services.size());
  if (ok) {
    fifo_pid_.resize(k.services.size());
    fifo_pid_[s.id.value()] = pid;  // watch_liveness holds it to the chain's deadline
    if (fifo_refusal_said_[s.id.value()]) {
      fifo_refusal_said_[s.id.value()] = false;
      k.log("real-time plan: '%s' at SCHED_FIFO again", s.name.c_str());
    }
    return;
  }
  // A restored copy is moved from `images/` into `live/` by the placer, after the rollback (docs/sandbox.md);
  // in `images/`, whose real-time budget is 0 (v1 RT groups), SCHED_FIFO is refused: again once it is there —
  // in every hierarchy, the v1 cpu one (the budget) after the v2 one. A refusal while the placer is between the
  // two is not final: the copy is tried again once settled (keep_realtime_plan), else it would run SCHED_OTHER.
  if (s.sandbox.cgroup.valid() && !s.sandbox.cgroup.settled_in(pid, sys::CgroupLeaf::Live)) {
    realtime_pending_.emplace_back(s.id, pid);
    return;
  }
  // v1 RT groups: the budgets of all groups under one parent add up to at most its own (the machine's 950 ms/s at
  // the top), so a kernel started while others hold theirs may find none left for this service's group. A refusal
  // once settled is tried again every 100 ms (keep_realtime_plan): the scheduler's group follows a move a moment
  // after /proc/<pid>/cgroup shows it. Said once per service, and once more when it is given (above).
  if (fifo_refusal_said_[s.id.value()]) return;
  fifo_refusal_said_[s.id.value()] = true;
  const bool no_budget = s.sandbox.cgroup.valid() && s.sandbox.cgroup.rt_budget_refused();
  k.log("real-time plan: '%s' refused SCHED_FIFO (%s)%s; it runs SCHED_OTHER, asked again every 100 ms",
        s.name.c_str(), ok.error().to_string().c_str(),
        no_budget ? ": its cgroup got no real-time budget (cpu.rt_runtime_us refused: other real-time kernels on this "
                    "machine hold the rest of its 950 ms/s)"
                  : "");
}

void Supervisor::keep_realtime_plan() {
  // Taken out first: apply_realtime may queue the copy again (refused and no longer found in `live/`).
  const std::vector<std::pair<ServiceId, pid_t>> pending = std::exchange(realtime_pending_, {});
  for (const auto& [id, pid] : pending) {
    ServiceRuntime& s = k.services[id.value()];
    if (!s.live() || s.proc.process.pid() != pid) continue;  // another incarnation since: its own turn
    if (!s.sandbox.cgroup.settled_in(pid, sys::CgroupLeaf::Live)) {
      realtime_pending_.emplace_back(id, pid);  // not moved yet (in every hierarchy)
      continue;
    }
    apply_realtime(s);
  }
  if (!realtime_active) return;
  // Every live service of the plan not at SCHED_FIFO now (refused once settled, or moved off it by anyone) is
  // given it again; the catch-up chain stays off it while it replays (chain_realtime gives it back after).
  for (ServiceRuntime& s : k.services) {
    if (s.config.spec == nullptr || s.config.spec->rt_priority() == 0 || !s.live() || s.proc.phase() != Phase::Ready ||
        k.rejuvenator.catch_up().in_replay(s.id)) {
      continue;
    }
    const pid_t pid = s.proc.process.pid();
    const bool queued = std::any_of(realtime_pending_.begin(), realtime_pending_.end(),
                                    [&](const auto& p) { return p.first == s.id && p.second == pid; });
    if (!queued && !sys::runs_fifo(pid)) apply_realtime(s);
  }
}

}  // namespace rejuv::kernel
