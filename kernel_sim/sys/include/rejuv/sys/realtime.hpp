// Real-time scheduling for the kernel's real-time plan (idl/launch.proto RealtimePlan;
// docs/realtime.md): SCHED_FIFO with SCHED_RESET_ON_FORK (what a process or thread so scheduled makes runs
// SCHED_OTHER), CPU pinning and mlockall (RLIMIT_RTTIME is set at spawn: ResourceLimits::rt_time_us). Each needs
// CAP_SYS_NICE / CAP_IPC_LOCK (or the matching rlimits); the caller decides what a refusal means.
#pragma once

#include <sys/types.h>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// Thread or process `tid` (0: the calling thread) at SCHED_FIFO `priority` (1…99), SCHED_RESET_ON_FORK.
[[nodiscard]] SysResult<void> set_fifo(pid_t tid, int priority);
// Every thread of this process (those it has now; later ones inherit the creating thread's policy).
[[nodiscard]] SysResult<void> set_fifo_all_threads(int priority);
// Whether thread or process `tid` runs SCHED_FIFO now (false where it cannot be read: gone).
[[nodiscard]] bool runs_fifo(pid_t tid);
// Thread or process `tid` (0: the calling thread) pinned to CPU `cpu` (sched_setaffinity); EINVAL if the
// machine has no such CPU online.
[[nodiscard]] SysResult<void> pin_to_cpu(pid_t tid, unsigned cpu);
// Every thread of this process (those it has now; later ones inherit the creating thread's affinity).
[[nodiscard]] SysResult<void> pin_all_threads(unsigned cpu);
// mlockall(MCL_CURRENT | MCL_FUTURE) of this process.
[[nodiscard]] SysResult<void> lock_all_memory();

}  // namespace rejuv::sys
