#include "rejuv/sys/realtime.hpp"

#include <dirent.h>
#include <sched.h>
#include <sys/mman.h>

#include <cstdlib>
#include <string>

namespace rejuv::sys {

SysResult<void> set_fifo(pid_t tid, int priority) {
  const sched_param param{.sched_priority = priority};
  if (::sched_setscheduler(tid, SCHED_FIFO | SCHED_RESET_ON_FORK, &param) != 0) return last_error("sched_setscheduler");
  return {};
}

bool runs_fifo(pid_t tid) {
  const int policy = ::sched_getscheduler(tid);
  return policy >= 0 && (policy & ~SCHED_RESET_ON_FORK) == SCHED_FIFO;
}

namespace {
// `apply` on every thread of this process; the first refusal, after trying every thread.
template <class Apply>
SysResult<void> for_all_threads(Apply apply) {
  DIR* tasks = ::opendir("/proc/self/task");
  if (tasks == nullptr) return last_error("opendir(/proc/self/task)");
  SysResult<void> out{};
  while (const dirent* entry = ::readdir(tasks)) {
    if (entry->d_name[0] < '0' || entry->d_name[0] > '9') continue;
    const auto tid = static_cast<pid_t>(std::strtol(entry->d_name, nullptr, 10));
    if (auto ok = apply(tid); !ok && out) out = ok;
  }
  ::closedir(tasks);
  return out;
}
}  // namespace

SysResult<void> set_fifo_all_threads(int priority) {
  return for_all_threads([&](pid_t tid) { return set_fifo(tid, priority); });
}

SysResult<void> pin_to_cpu(pid_t tid, unsigned cpu) {
  if (cpu >= CPU_SETSIZE) return std::unexpected(SysError{"sched_setaffinity", EINVAL});
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  if (::sched_setaffinity(tid, sizeof set, &set) != 0) return last_error("sched_setaffinity");
  return {};
}

SysResult<void> pin_all_threads(unsigned cpu) {
  return for_all_threads([&](pid_t tid) { return pin_to_cpu(tid, cpu); });
}

SysResult<void> lock_all_memory() {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) != 0) return last_error("mlockall");
  return {};
}

}  // namespace rejuv::sys
