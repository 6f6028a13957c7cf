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

SysResult<void> set_fifo_all_threads(int priority) {
  DIR* tasks = ::opendir("/proc/self/task");
  if (tasks == nullptr) return last_error("opendir(/proc/self/task)");
  SysResult<void> out{};
  while (const dirent* entry = ::readdir(tasks)) {
    if (entry->d_name[0] < '0' || entry->d_name[0] > '9') continue;
    const auto tid = static_cast<pid_t>(std::strtol(entry->d_name, nullptr, 10));
    if (auto ok = set_fifo(tid, priority); !ok && out) out = ok;  // the first refusal, after trying every thread
  }
  ::closedir(tasks);
  return out;
}

SysResult<void> lock_all_memory() {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) != 0) return last_error("mlockall");
  return {};
}

}  // namespace rejuv::sys
