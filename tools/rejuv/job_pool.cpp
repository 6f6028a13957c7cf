#include "job_pool.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <thread>
#include <utility>

namespace rejuv::cli {
namespace {

using Clock = std::chrono::steady_clock;

// A task's process in flight in a slot.
struct Running {
  std::size_t task = 0;
  sys::ChildProcess child;
  Clock::time_point start;
};

bool interrupted_by(const sys::SignalFd* signals) {
  if (signals == nullptr) return false;
  auto sig = signals->read();
  return sig && *sig;
}

}  // namespace

Result<JobPool, std::string> JobPool::create(const PoolConfig& config) {
  const long cpus = std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN));
  std::vector<sys::DdsDomainLease> leases;
  std::vector<WorkerSlot> slots;
  for (std::uint32_t j = 0; j < std::max(1U, config.workers); ++j) {
    std::uint32_t domain = 0;
    if (config.first_domain) {
      domain = *config.first_domain + j;
    } else {
      auto lease = sys::lease_dds_domain_for_worker(j);
      if (!lease) return fail(lease.error().to_string());
      domain = lease->slot();
      leases.push_back(std::move(*lease));
    }
    slots.push_back(WorkerSlot{.index = j, .dds_domain = domain, .cpu = static_cast<int>(j % static_cast<unsigned long>(cpus))});
  }
  return JobPool(config, std::move(leases), std::move(slots));
}

Result<PoolOutcome, std::string> JobPool::run(std::size_t count, const StartTask& start, const PoolHooks& hooks) {
  // Dropped on any return: a worker still running is killed and reaped (sys::ChildProcess).
  std::vector<std::optional<Running>> running(slots_.size());
  std::size_t next = 0, busy = 0;
  std::optional<Clock::time_point> interrupted_at;
  while ((next < count && !interrupted_at) || busy > 0) {
    for (std::size_t j = 0; j < slots_.size() && next < count && !interrupted_at; ++j) {
      if (running[j]) continue;
      auto child = start(next, slots_[j]);
      if (!child) return fail(child.error());
      running[j].emplace(Running{.task = next++, .child = std::move(*child), .start = Clock::now()});
      ++busy;
    }
    std::this_thread::sleep_for(config_.poll);
    if (!interrupted_at && interrupted_by(config_.signals)) {
      interrupted_at = Clock::now();  // each worker stops cleanly (a kernel shuts its processes down)
      for (auto& r : running) {
        if (r) (void)r->child.signal(SIGTERM);
      }
    }
    for (std::size_t j = 0; j < slots_.size(); ++j) {
      if (!running[j]) continue;
      auto status = running[j]->child.try_wait();
      if (!status) return fail("waiting for a worker: " + status.error().to_string());
      if (!*status) {
        if (interrupted_at && Clock::now() - *interrupted_at > config_.grace) {
          running[j]->child.kill_and_reap();
          running[j].reset();
          --busy;
        }
        continue;
      }
      const TaskEnd end{.task = running[j]->task,
                        .slot = slots_[j],
                        .status = **status,
                        .wall = Clock::now() - running[j]->start};
      running[j].reset();
      --busy;
      if (!interrupted_at && hooks.ended) {
        if (auto ok = hooks.ended(end); !ok) return fail(ok.error());
      }
    }
    if (hooks.tick) hooks.tick();
  }
  return interrupted_at ? PoolOutcome::Interrupted : PoolOutcome::Done;
}

StartTask forked(std::function<int(std::size_t task, const WorkerSlot& slot)> body) {
  return [body = std::move(body)](std::size_t task, const WorkerSlot& slot) -> Result<sys::ChildProcess, std::string> {
    auto child = sys::fork_worker([&] { return body(task, slot); });
    if (!child) return fail("cannot start a worker: " + child.error().to_string());
    return std::move(*child);
  };
}

}  // namespace rejuv::cli
