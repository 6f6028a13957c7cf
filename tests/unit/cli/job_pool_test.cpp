// The worker pool of `rejuv faults` and `rejuv sweep` (tools/rejuv/job_pool.hpp) with real forked workers:
// every task runs once and is reported with its exit status, the DDS-domain rule, and no worker outlives the
// pool when a task cannot start, its end cannot be kept or the pool is interrupted.
#include "job_pool.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <set>
#include <vector>

namespace rejuv::cli {
namespace {

// A worker that waits to be killed (SIGTERM is blocked in it when the test holds a signalfd).
int wait_forever(std::size_t, const WorkerSlot&) {
  for (;;) ::pause();
}

bool gone(pid_t pid) { return ::kill(pid, 0) != 0 && errno == ESRCH; }

TEST(JobPool, TasksOverFewerWorkers_EveryTaskEndsOnceWithItsExitCode) {
  auto pool = JobPool::create(PoolConfig{.workers = 2, .first_domain = 50});
  ASSERT_TRUE(pool) << pool.error();
  std::vector<TaskEnd> ends;
  const auto outcome = pool->run(5, forked([](std::size_t task, const WorkerSlot&) { return static_cast<int>(task) + 10; }),
                                 PoolHooks{.ended = [&](const TaskEnd& e) -> Result<void, std::string> {
                                   ends.push_back(e);
                                   return {};
                                 }});
  ASSERT_TRUE(outcome) << outcome.error();
  EXPECT_EQ(*outcome, PoolOutcome::Done);
  ASSERT_EQ(ends.size(), 5U);
  std::set<std::size_t> tasks;
  for (const TaskEnd& e : ends) {
    tasks.insert(e.task);
    EXPECT_EQ(e.status.how, sys::ExitStatus::How::Exited);
    EXPECT_EQ(e.status.value, static_cast<int>(e.task) + 10);
  }
  EXPECT_EQ(tasks.size(), 5U);
}

TEST(JobPool, FirstDomainGiven_SlotJUsesDomainPlusJ) {
  auto pool = JobPool::create(PoolConfig{.workers = 3, .first_domain = 60});
  ASSERT_TRUE(pool) << pool.error();
  ASSERT_EQ(pool->slots().size(), 3U);
  for (std::uint32_t j = 0; j < 3; ++j) EXPECT_EQ(pool->slots()[j].dds_domain, 60 + j);
}

TEST(JobPool, NoDomainGiven_SlotsLeaseDistinctDomains) {
  auto pool = JobPool::create(PoolConfig{.workers = 3});
  ASSERT_TRUE(pool) << pool.error();
  std::set<std::uint32_t> domains;
  for (const WorkerSlot& s : pool->slots()) {
    EXPECT_GE(s.dds_domain, 1U);
    EXPECT_LE(s.dds_domain, sys::kLeasedDdsDomains);
    domains.insert(s.dds_domain);
  }
  EXPECT_EQ(domains.size(), 3U);
  // Another pool of this machine gets other domains while this one holds its own.
  auto other = JobPool::create(PoolConfig{.workers = 1});
  ASSERT_TRUE(other) << other.error();
  EXPECT_FALSE(domains.contains(other->slots().front().dds_domain));
}

TEST(JobPool, TaskCannotStart_ErrorAndRunningWorkersKilled) {
  auto pool = JobPool::create(PoolConfig{.workers = 2, .first_domain = 70});
  ASSERT_TRUE(pool) << pool.error();
  const StartTask fork = forked(wait_forever);
  std::vector<pid_t> started;
  const auto outcome = pool->run(2, [&](std::size_t task, const WorkerSlot& slot) -> Result<sys::ChildProcess, std::string> {
    if (task == 1) return fail(std::string("task 1 cannot start"));
    auto child = fork(task, slot);
    if (child) started.push_back(child->pid());
    return child;
  });
  ASSERT_FALSE(outcome);
  EXPECT_EQ(outcome.error(), "task 1 cannot start");
  ASSERT_EQ(started.size(), 1U);
  EXPECT_TRUE(gone(started.front()));
}

TEST(JobPool, EndedHookFails_ErrorAndRunningWorkersKilled) {
  auto pool = JobPool::create(PoolConfig{.workers = 2, .first_domain = 75});
  ASSERT_TRUE(pool) << pool.error();
  const StartTask quick = forked([](std::size_t, const WorkerSlot&) { return 0; });
  const StartTask stays = forked(wait_forever);
  std::vector<pid_t> started;
  const auto outcome = pool->run(
      2,
      [&](std::size_t task, const WorkerSlot& slot) {
        auto child = task == 0 ? quick(task, slot) : stays(task, slot);
        if (child) started.push_back(child->pid());
        return child;
      },
      PoolHooks{.ended = [](const TaskEnd&) -> Result<void, std::string> { return fail(std::string("cannot keep it")); }});
  ASSERT_FALSE(outcome);
  EXPECT_EQ(outcome.error(), "cannot keep it");
  ASSERT_EQ(started.size(), 2U);
  for (const pid_t pid : started) EXPECT_TRUE(gone(pid));
}

TEST(JobPool, Interrupted_StopsStartingAndKillsWorkersAfterGrace) {
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  ASSERT_TRUE(signals);
  ASSERT_EQ(::raise(SIGINT), 0);  // pending (blocked): the pool reads it at its first look
  auto pool = JobPool::create(
      PoolConfig{.workers = 2, .first_domain = 80, .signals = &*signals, .grace = std::chrono::seconds{0}});
  ASSERT_TRUE(pool) << pool.error();
  const StartTask fork = forked(wait_forever);
  std::vector<pid_t> started;
  bool ended = false;
  const auto outcome = pool->run(
      10,
      [&](std::size_t task, const WorkerSlot& slot) {
        auto child = fork(task, slot);
        if (child) started.push_back(child->pid());
        return child;
      },
      PoolHooks{.ended = [&](const TaskEnd&) -> Result<void, std::string> {
        ended = true;
        return {};
      }});
  ASSERT_TRUE(outcome) << outcome.error();
  EXPECT_EQ(*outcome, PoolOutcome::Interrupted);
  EXPECT_EQ(started.size(), 2U);  // one per slot, none after the interrupt
  EXPECT_FALSE(ended);
  for (const pid_t pid : started) EXPECT_TRUE(gone(pid));
}

}  // namespace
}  // namespace rejuv::cli
