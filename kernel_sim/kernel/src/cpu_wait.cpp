// cpu_sight: what the scheduler gives a set of processes, for CpuWait and the liveness watch (cpu_wait.hpp).
#include "cpu_wait.hpp"

#include "rejuv/sys/process.hpp"

namespace rejuv::kernel {

std::optional<CpuSight> cpu_sight(std::span<const pid_t> pids) {
  std::optional<CpuSight> sum;
  for (const pid_t pid : pids) {
    auto cpu = sys::task_cpu(pid);
    if (!cpu) continue;  // gone meanwhile, or never ours
    if (!sum) sum = CpuSight{};
    sum->ran += cpu->ran;
    sum->runnable = sum->runnable || cpu->runnable;
  }
  return sum;
}

}  // namespace rejuv::kernel
