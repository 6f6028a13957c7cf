// The image coordinator's parts as owners of their state (kernel_sim/kernel/src; docs/design.md §6, §7): Reaper, the
// processes the kernel is done with, on real child processes; ChannelPool, socket pairs made ahead, on real
// fds; RoutingFreeze, the bridge writes held while image work is timed; ImageCharge, the simulated time a
// checkpoint or a rollback costs the plant's world. Conditions are waited for (waitid, the reaper's own
// settle), never slept for.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <string>
#include <utility>
#include <vector>

#include "channel_pool.hpp"
#include "image_charge.hpp"
#include "reaper.hpp"
#include "routing_freeze.hpp"

namespace rejuv::kernel {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;
using std::chrono::seconds;

// A child of this process that waits for a signal, in the kernel's charge.
sys::ChildProcess child() {
  const pid_t pid = ::fork();
  if (pid == 0) {
    for (;;) ::pause();
  }
  EXPECT_GT(pid, 0) << "fork";
  auto adopted = sys::ChildProcess::adopt_child(pid);
  EXPECT_TRUE(adopted.has_value()) << adopted.error().to_string();
  return adopted ? std::move(*adopted) : sys::ChildProcess{};
}

// Waits (waitid without reaping) until `pid` has stopped.
bool wait_stopped(pid_t pid) {
  siginfo_t info{};
  return ::waitid(P_PID, static_cast<id_t>(pid), &info, WSTOPPED | WNOWAIT) == 0 &&
         info.si_code == CLD_STOPPED;
}

// Whether `pid` is a process (a zombie counts: not reaped yet).
bool exists(pid_t pid) {
  return ::kill(pid, 0) == 0;
}

TEST(Reaper, Retire_StopsAtOnce_KillRetiredKills_SettleReaps) {
  Reaper reaper;
  sys::ChildProcess p = child();
  const pid_t pid = p.pid();
  ASSERT_GT(pid, 0);
  reaper.retire(std::move(p));
  EXPECT_TRUE(wait_stopped(pid)) << "a retired incarnation is stopped";
  EXPECT_TRUE(reaper.knows(pid));
  reaper.kill_retired();
  EXPECT_TRUE(reaper.knows(pid)) << "killed, not reaped yet: it still holds a process slot";
  reaper.set_slack(0);
  reaper.settle(sys::monotonic_now() + seconds{30});
  EXPECT_FALSE(reaper.knows(pid));
  EXPECT_FALSE(exists(pid)) << "reaped";
}

TEST(Reaper, Settle_WaitsOnlyWhileMoreAreDyingThanTheSlack) {
  Reaper reaper;
  sys::ChildProcess a = child();
  sys::ChildProcess b = child();
  const pid_t pa = a.pid();
  const pid_t pb = b.pid();
  reaper.kill(std::move(a));
  reaper.kill(std::move(b));
  reaper.set_slack(1);
  reaper.settle(sys::monotonic_now() + seconds{30});
  EXPECT_LE(int{reaper.knows(pa)} + int{reaper.knows(pb)}, 1) << "no more dying than the slack";
  reaper.set_slack(0);
  reaper.settle(sys::monotonic_now() + seconds{30});
  EXPECT_FALSE(reaper.knows(pa));
  EXPECT_FALSE(reaper.knows(pb));
}

TEST(Reaper, KillAllAndReap_LeavesNoProcess) {
  Reaper reaper;
  sys::ChildProcess retired = child();
  sys::ChildProcess dying = child();
  const pid_t pr = retired.pid();
  const pid_t pd = dying.pid();
  reaper.retire(std::move(retired));
  reaper.kill(std::move(dying));
  reaper.kill_all_and_reap();
  EXPECT_FALSE(reaper.knows(pr));
  EXPECT_FALSE(reaper.knows(pd));
  EXPECT_FALSE(exists(pr));
  EXPECT_FALSE(exists(pd));
  EXPECT_FALSE(reaper.knows(::getpid())) << "not a process it was given";
}

// ---- ChannelPool ----

bool nonblocking(int fd) {
  return (::fcntl(fd, F_GETFL) & O_NONBLOCK) != 0;
}
bool open_fd(int fd) {
  return ::fcntl(fd, F_GETFD) != -1;
}

TEST(ChannelPool, Refill_MakesPairsAhead_TakeHandsThemOut_ThenMakesOne) {
  ChannelPool pool;
  ASSERT_FALSE(pool.refill(2).has_value());
  const sys::UniqueFd marker(::open("/dev/null", O_RDONLY | O_CLOEXEC));  // an fd opened after the refill
  ASSERT_TRUE(marker.valid());
  std::vector<ChannelPool::Pair> taken;  // kept open, so that no fd number is reused below
  for (int i = 0; i < 2; ++i) {
    auto pair = pool.take();
    ASSERT_TRUE(pair.has_value()) << pair.error().to_string();
    EXPECT_LT(pair->first.fd(), marker.get()) << "made ahead, at the refill";
    EXPECT_TRUE(nonblocking(pair->first.fd())) << "the kernel's end";
    EXPECT_FALSE(nonblocking(pair->second.fd())) << "the service's end";
    const std::byte b[] = {std::byte{42}};
    ASSERT_TRUE(pair->first.send(b).has_value());
    std::byte got[8]{};
    auto r = pair->second.receive(got);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->size, 1U);
    EXPECT_EQ(got[0], std::byte{42}) << "a connected pair";
    taken.push_back(std::move(*pair));
  }
  auto made_now = pool.take();
  ASSERT_TRUE(made_now.has_value()) << "the pool is empty: one made now";
  EXPECT_GT(made_now->first.fd(), marker.get());
  EXPECT_TRUE(nonblocking(made_now->first.fd()));
}

TEST(ChannelPool, CloseLater_ClosedAtTheNextRefill) {
  ChannelPool pool;
  int fds[2];
  ASSERT_EQ(::pipe2(fds, O_CLOEXEC), 0);
  const sys::UniqueFd keep(fds[1]);
  pool.close_later(sys::UniqueFd(fds[0]));
  EXPECT_TRUE(open_fd(fds[0])) << "not during the timed part";
  ASSERT_FALSE(pool.refill(0).has_value());
  EXPECT_FALSE(open_fd(fds[0]));
}

// Lowers this process's soft fd limit to the lowest free fd (no new fd can be opened) until destroyed.
class NoNewFds {
 public:
  NoNewFds() {
    ::getrlimit(RLIMIT_NOFILE, &saved_);
    const int lowest_free = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    ::close(lowest_free);
    rlimit low = saved_;
    low.rlim_cur = static_cast<rlim_t>(lowest_free);
    ok_ = lowest_free >= 0 && ::setrlimit(RLIMIT_NOFILE, &low) == 0;
  }
  ~NoNewFds() { ::setrlimit(RLIMIT_NOFILE, &saved_); }
  NoNewFds(const NoNewFds&) = delete;
  NoNewFds& operator=(const NoNewFds&) = delete;
  [[nodiscard]] bool ok() const { return ok_; }

 private:
  rlimit saved_{};
  bool ok_ = false;
};

TEST(ChannelPool, OutOfFds_TheShortageReportedOncePerShortage_AndTakeReturnsTheError) {
  ChannelPool pool;
  {
    NoNewFds limit;
    ASSERT_TRUE(limit.ok());
    const auto first = pool.refill(1);
    ASSERT_TRUE(first.has_value()) << "a shortage is reported";
    EXPECT_EQ(first->error, EMFILE);
    EXPECT_FALSE(pool.refill(1).has_value()) << "once per shortage";
    auto taken = pool.take();
    ASSERT_FALSE(taken.has_value());
    EXPECT_EQ(taken.error().error, EMFILE);
  }
  EXPECT_FALSE(pool.refill(1).has_value()) << "fds again: a pair made";
  ASSERT_TRUE(pool.take().has_value());
  NoNewFds limit;
  ASSERT_TRUE(limit.ok());
  EXPECT_TRUE(pool.refill(1).has_value()) << "a new shortage is reported again";
}

// ---- RoutingFreeze ----

using Written = std::vector<std::pair<std::uint32_t, std::vector<std::byte>>>;

std::vector<std::byte> payload(std::uint8_t b) {
  return {std::byte{b}, std::byte{b}};
}

TEST(RoutingFreeze, Thaw_WritesTheHeldWritesInOrder_ThenNothingIsHeld) {
  RoutingFreeze freeze;
  EXPECT_FALSE(freeze.frozen());
  freeze.freeze();
  EXPECT_TRUE(freeze.frozen());
  freeze.hold(ObjectId{2}, payload(1));
  freeze.hold(ObjectId{1}, payload(2));
  freeze.hold(ObjectId{2}, payload(3));
  Written written;
  const auto write = [&](ObjectId topic, std::span<const std::byte> p) {
    written.emplace_back(topic.value(), std::vector<std::byte>(p.begin(), p.end()));
    return true;
  };
  freeze.thaw(write);
  EXPECT_FALSE(freeze.frozen());
  EXPECT_EQ(written, (Written{{2, payload(1)}, {1, payload(2)}, {2, payload(3)}}));
  written.clear();
  freeze.freeze();
  freeze.thaw(write);
  EXPECT_TRUE(written.empty()) << "each held write goes out once";
}

TEST(RoutingFreeze, AFailedWrite_StopsTheThaw_TheRestDropped) {
  RoutingFreeze freeze;
  freeze.freeze();
  for (std::uint8_t i = 1; i <= 3; ++i) freeze.hold(ObjectId{i}, payload(i));
  std::vector<std::uint32_t> tried;
  freeze.thaw([&](ObjectId topic, std::span<const std::byte>) {
    tried.push_back(topic.value());
    return topic.value() != 2;
  });
  EXPECT_EQ(tried, (std::vector<std::uint32_t>{1, 2}));
  tried.clear();
  freeze.freeze();
  freeze.thaw([&](ObjectId topic, std::span<const std::byte>) {
    tried.push_back(topic.value());
    return true;
  });
  EXPECT_TRUE(tried.empty()) << "the write after the failed one is dropped, not kept";
}

TEST(RoutingFreezeDeathTest, HoldWhileRouting_BreaksTheInvariant) {
  RoutingFreeze freeze;
  EXPECT_DEATH(freeze.hold(ObjectId{1}, payload(1)), "writes are held only while routing is frozen");
}

// ---- ImageCharge ----

TEST(ImageCharge, LockstepModel_ChargesTheModel_MeasuresTheRealDuration) {
  ImageCharge charge(ClockMode::Lockstep, KernelOptions::Charge::Model, milliseconds{3}, milliseconds{2}, microseconds{2});
  EXPECT_FALSE(charge.vehicle_sees_work());
  SrStats stats;
  charge.checkpoint(milliseconds{10}, stats);
  charge.rollback(milliseconds{7}, stats);
  EXPECT_EQ(stats.measured, milliseconds{17});
  EXPECT_EQ(stats.charged, milliseconds{5});
  EXPECT_EQ(charge.take_step_charge(), milliseconds{5});
  EXPECT_EQ(charge.take_step_charge(), Nanos{0}) << "the next step starts from zero";
  charge.checkpoint(milliseconds{1}, stats);
  EXPECT_EQ(charge.take_step_charge(), milliseconds{3});
  EXPECT_EQ(stats.charged, milliseconds{8}) << "the run's total goes on";
}

TEST(ImageCharge, CatchUp_ChargesItsSamplesByTheModel_MeasuresTheRealDuration) {
  ImageCharge model(ClockMode::Lockstep, KernelOptions::Charge::Model, milliseconds{3}, milliseconds{2}, microseconds{2});
  SrStats stats;
  model.catch_up(milliseconds{4}, 100, stats);
  EXPECT_EQ(model.take_step_charge(), microseconds{200});
  EXPECT_EQ(stats.measured, milliseconds{4});
  ImageCharge measured(ClockMode::Lockstep, KernelOptions::Charge::Measured, milliseconds{3}, milliseconds{2},
                       microseconds{2});
  measured.catch_up(milliseconds{4}, 100, stats);
  EXPECT_EQ(measured.take_step_charge(), milliseconds{4});
}

TEST(ImageCharge, LockstepMeasured_ChargesTheRealDuration) {
  ImageCharge charge(ClockMode::Lockstep, KernelOptions::Charge::Measured, milliseconds{3}, milliseconds{2}, microseconds{2});
  EXPECT_TRUE(charge.vehicle_sees_work());
  SrStats stats;
  charge.checkpoint(milliseconds{10}, stats);
  charge.rollback(milliseconds{7}, stats);
  EXPECT_EQ(stats.charged, milliseconds{17});
  EXPECT_EQ(stats.measured, milliseconds{17});
  EXPECT_EQ(charge.take_step_charge(), milliseconds{17});
}

TEST(ImageCharge, Realtime_ChargesNothing_TheWorldWentOn) {
  ImageCharge charge(ClockMode::Realtime, KernelOptions::Charge::Model, milliseconds{3}, milliseconds{2}, microseconds{2});
  EXPECT_TRUE(charge.vehicle_sees_work());
  SrStats stats;
  charge.checkpoint(milliseconds{10}, stats);
  charge.rollback(milliseconds{7}, stats);
  EXPECT_EQ(stats.measured, milliseconds{17});
  EXPECT_EQ(stats.charged, Nanos{0});
  EXPECT_EQ(charge.take_step_charge(), Nanos{0});
}

}  // namespace
}  // namespace rejuv::kernel
