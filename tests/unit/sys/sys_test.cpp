#include <gtest/gtest.h>

#include <signal.h>
#include <sched.h>
#include <sys/syscall.h>
#include <sys/resource.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/landlock.hpp"
#include "rejuv/sys/seccomp.hpp"

namespace rejuv::sys {
namespace {

const std::string kProbe = std::string(REJUV_BINARY_DIR) + "/tests/unit/sys/seccomp_probe";

SpawnSpec probe(std::string what) { return SpawnSpec{.executable = kProbe, .args = {std::move(what)}}; }

int exit_code_of(const SpawnSpec& spec) {
  auto child = spawn(spec);
  EXPECT_TRUE(child.has_value()) << (child ? "" : child.error().to_string());
  if (!child) return -1;
  const auto status = child->wait();
  EXPECT_TRUE(status.has_value());
  EXPECT_EQ(status->how, ExitStatus::How::Exited) << status->to_string();
  return status->value;
}

bool process_exists(pid_t pid) { return ::kill(pid, 0) == 0 || errno != ESRCH; }

TEST(UniqueFd, Move_LeavesSourceEmptyAndClosesOnce) {
  auto pair = SeqPacket::pair();
  ASSERT_TRUE(pair.has_value());
  UniqueFd a = pair->first.take_fd();
  const int raw = a.get();
  UniqueFd b = std::move(a);
  EXPECT_FALSE(a.valid());  // NOLINT(bugprone-use-after-move): the moved-from state is the point
  EXPECT_EQ(b.get(), raw);
  b.reset();
  b.reset();  // twice is safe
  EXPECT_FALSE(b.valid());
}

TEST(SeqPacket, SendReceive_KeepsFrameBoundaries) {
  auto pair = SeqPacket::pair();
  ASSERT_TRUE(pair.has_value());
  const std::array<std::byte, 3> one{std::byte{1}, std::byte{2}, std::byte{3}};
  const std::array<std::byte, 1> two{std::byte{9}};
  ASSERT_TRUE(pair->first.send(one).has_value());
  ASSERT_TRUE(pair->first.send(two).has_value());
  std::array<std::byte, 16> buf{};
  auto r1 = pair->second.receive(buf);
  ASSERT_TRUE(r1.has_value());
  EXPECT_EQ(r1->size, 3U);
  auto r2 = pair->second.receive(buf);
  ASSERT_TRUE(r2.has_value());
  EXPECT_EQ(r2->size, 1U);
  EXPECT_EQ(buf[0], std::byte{9});
}

// A service's channel blocks for its reads only: a send to a full channel says so instead of waiting.
TEST(SeqPacket, Send_FullBlockingChannel_EagainNotAWait) {
  auto pair = SeqPacket::pair(Blocking::Yes);
  ASSERT_TRUE(pair.has_value());
  const std::array<std::byte, 512> frame{};
  SysResult<void> sent;
  for (int i = 0; i < 100000 && sent; ++i) sent = pair->first.send(frame);  // nobody reads the other end
  ASSERT_FALSE(sent.has_value());
  EXPECT_EQ(sent.error().error, EAGAIN);
}

TEST(SeqPacket, Receive_OversizedFrame_ReportedTruncated) {
  auto pair = SeqPacket::pair();
  ASSERT_TRUE(pair.has_value());
  const std::array<std::byte, 64> big{};
  ASSERT_TRUE(pair->first.send(big).has_value());
  std::array<std::byte, 8> small{};
  auto r = pair->second.receive(small);
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->truncated);
  EXPECT_EQ(r->size, 8U);
}

TEST(SeqPacket, Receive_PeerClosed_ReportsClosed) {
  auto pair = SeqPacket::pair();
  ASSERT_TRUE(pair.has_value());
  pair->first.close();
  std::array<std::byte, 8> buf{};
  auto r = pair->second.receive(buf);
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->closed);
}

TEST(SeqPacket, Receive_NonBlockingEmpty_EagainAsValue) {
  auto pair = SeqPacket::pair(Blocking::No);
  ASSERT_TRUE(pair.has_value());
  std::array<std::byte, 8> buf{};
  auto r = pair->second.receive(buf);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().error, EAGAIN);
}

// ---- receive_batch (one recvmmsg for a burst: the kernel's read_channel) ----

// kMaxReceiveBatch slots of 16 bytes, contiguous, as the kernel and the SDK give them.
struct BatchBuffers {
  static constexpr std::size_t kSlot = 16;
  std::array<std::byte, kSlot * kMaxReceiveBatch> bytes{};
  std::array<Received, kMaxReceiveBatch> out{};
  [[nodiscard]] std::byte at(std::size_t slot, std::size_t i) const { return bytes[slot * kSlot + i]; }
};

TEST(SeqPacketBatch, ThreeFrames_OneCallInOrderWithBoundaries) {
  auto pair = SeqPacket::pair(Blocking::No);
  ASSERT_TRUE(pair.has_value());
  for (std::uint8_t i = 1; i <= 3; ++i) {
    const std::array<std::byte, 2> frame{std::byte{i}, std::byte{i}};
    ASSERT_TRUE(pair->first.send(std::span(frame).first(i == 2 ? 1 : 2)).has_value());
  }
  BatchBuffers b;
  auto n = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_TRUE(n.has_value()) << n.error().to_string();
  ASSERT_EQ(*n, 3U);
  EXPECT_EQ(b.out[0].size, 2U);
  EXPECT_EQ(b.out[1].size, 1U);
  EXPECT_EQ(b.out[2].size, 2U);
  EXPECT_EQ(b.at(2, 0), std::byte{3});
  auto again = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_FALSE(again.has_value());
  EXPECT_EQ(again.error().error, EAGAIN);
}

TEST(SeqPacketBatch, MoreFramesThanSlots_RestOnTheNextCall) {
  auto pair = SeqPacket::pair(Blocking::No);
  ASSERT_TRUE(pair.has_value());
  const std::array<std::byte, 1> frame{std::byte{5}};
  for (std::size_t i = 0; i < kMaxReceiveBatch + 3; ++i) ASSERT_TRUE(pair->first.send(frame).has_value());
  BatchBuffers b;
  auto first = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(*first, kMaxReceiveBatch);
  auto second = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(*second, 3U);
}

TEST(SeqPacketBatch, OversizedFrame_TruncatedFlaggedOthersIntact) {
  auto pair = SeqPacket::pair(Blocking::No);
  ASSERT_TRUE(pair.has_value());
  const std::array<std::byte, 64> big{};
  const std::array<std::byte, 4> small{std::byte{1}, std::byte{2}, std::byte{3}, std::byte{4}};
  ASSERT_TRUE(pair->first.send(big).has_value());
  ASSERT_TRUE(pair->first.send(small).has_value());
  BatchBuffers b;
  auto n = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_TRUE(n.has_value());
  ASSERT_EQ(*n, 2U);
  EXPECT_TRUE(b.out[0].truncated);
  EXPECT_FALSE(b.out[1].truncated);
  EXPECT_EQ(b.out[1].size, 4U);
  EXPECT_EQ(b.at(1, 3), std::byte{4});
}

TEST(SeqPacketBatch, UnexpectedFds_ClosedAndFlagged) {
  auto pair = SeqPacket::pair(Blocking::No);
  auto carried = SeqPacket::pair();
  ASSERT_TRUE(pair && carried);
  const auto before = count_open_fds();
  ASSERT_TRUE(before.has_value());
  const std::array<std::byte, 1> tag{std::byte{7}};
  const std::array<int, 2> fds{carried->first.fd(), carried->second.fd()};
  ASSERT_TRUE(pair->first.send(tag, fds).has_value());
  BatchBuffers b;
  auto n = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_TRUE(n.has_value());
  ASSERT_EQ(*n, 1U);
  EXPECT_TRUE(b.out[0].fds_truncated);
  EXPECT_TRUE(b.out[0].fds.empty());
  EXPECT_EQ(*count_open_fds(), *before);
}

// receive_into (no allocation, for frozen images): the fds that fit are handed over, the rest closed; a
// closed peer is size 0.
TEST(SeqPacket, ReceiveInto_FdsBeyondRoomClosed_ThenPeerClosedIsZero) {
  auto pair = SeqPacket::pair();
  auto carried = SeqPacket::pair();
  ASSERT_TRUE(pair && carried);
  const auto before = count_open_fds();
  ASSERT_TRUE(before.has_value());
  const std::array<std::byte, 3> frame{std::byte{1}, std::byte{2}, std::byte{3}};
  const std::array<int, 2> sent{carried->first.fd(), carried->second.fd()};
  ASSERT_TRUE(pair->first.send(frame, sent).has_value());
  std::array<std::byte, 16> buf{};
  std::array<int, 1> fds{-1};
  std::size_t count = 9;
  auto n = pair->second.receive_into(buf, fds, count);
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 3U);
  EXPECT_EQ(buf[2], std::byte{3});
  ASSERT_EQ(count, 1U);
  EXPECT_EQ(*count_open_fds(), *before + 1);  // the one handed over; the second was closed
  ::close(fds[0]);
  pair->first.close();
  n = pair->second.receive_into(buf, fds, count);
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(*n, 0U);
  EXPECT_EQ(count, 0U);
}

TEST(SeqPacketBatch, PeerClosed_EndsTheBatchWithClosed) {
  auto pair = SeqPacket::pair(Blocking::No);
  ASSERT_TRUE(pair.has_value());
  const std::array<std::byte, 1> frame{std::byte{1}};
  ASSERT_TRUE(pair->first.send(frame).has_value());
  pair->first.close();
  BatchBuffers b;
  auto n = pair->second.receive_batch(b.bytes, BatchBuffers::kSlot, b.out);
  ASSERT_TRUE(n.has_value());
  ASSERT_EQ(*n, 2U);
  EXPECT_FALSE(b.out[0].closed);
  EXPECT_TRUE(b.out[1].closed);
}

TEST(SeqPacket, PassFd_ArrivesUsable) {
  auto pair = SeqPacket::pair();
  auto carried = SeqPacket::pair();
  ASSERT_TRUE(pair && carried);
  const std::array<std::byte, 1> tag{std::byte{7}};
  const std::array<int, 1> fds{carried->first.fd()};
  ASSERT_TRUE(pair->first.send(tag, fds).has_value());
  std::array<std::byte, 4> buf{};
  auto r = pair->second.receive(buf, 1);
  ASSERT_TRUE(r.has_value());
  ASSERT_EQ(r->fds.size(), 1U);
  SeqPacket received(std::move(r->fds[0]));
  ASSERT_TRUE(received.send(tag).has_value());
  auto back = carried->second.receive(buf);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->size, 1U);
}

TEST(SeqPacket, UnexpectedFds_ClosedNotLeaked) {
  auto pair = SeqPacket::pair();
  auto carried = SeqPacket::pair();
  ASSERT_TRUE(pair && carried);
  const auto before = count_open_fds();
  ASSERT_TRUE(before.has_value());
  const std::array<std::byte, 1> tag{std::byte{7}};
  const std::array<int, 2> fds{carried->first.fd(), carried->second.fd()};
  ASSERT_TRUE(pair->first.send(tag, fds).has_value());
  std::array<std::byte, 4> buf{};
  auto r = pair->second.receive(buf, /*max_fds=*/0);
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->fds.empty());
  EXPECT_TRUE(r->fds_truncated);
  EXPECT_EQ(count_open_fds().value(), *before);
}

TEST(Spawn, ExitCode_Reported) {
  EXPECT_EQ(exit_code_of(SpawnSpec{.executable = "/bin/sh", .args = {"-c", "exit 3"}}), 3);
}

TEST(Spawn, MissingExecutable_ErrorValueWithErrno) {
  auto child = spawn(SpawnSpec{.executable = "/nonexistent/rejuv-service"});
  ASSERT_FALSE(child.has_value());
  EXPECT_EQ(child.error().call, "open(the executable, O_PATH)");  // opened by the spawner, exec'ed by fd
  EXPECT_EQ(child.error().error, ENOENT);
  EXPECT_NE(child.error().to_string().find("/nonexistent/rejuv-service"), std::string::npos);
}

// The child execs the fd the spawner opened: a binary behind a folder its uid cannot search (a 0700 home, a
// service run by a subordinate uid) still runs, as long as the binary itself may be executed.
TEST(Spawn, BinaryBehindAnUnsearchableFolder_RunsByFd) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root (to spawn as another uid)";
  char dir_template[] = "/tmp/rejuv_0700_XXXXXX";
  ASSERT_NE(::mkdtemp(dir_template), nullptr);
  ASSERT_EQ(::chmod(dir_template, 0700), 0);
  const std::filesystem::path bin = std::filesystem::path(dir_template) / "true";
  std::filesystem::copy_file("/bin/true", bin);
  ASSERT_EQ(::chmod(bin.c_str(), 0755), 0);
  EXPECT_EQ(exit_code_of(SpawnSpec{.executable = bin.string(), .uid = 65534}), 0);
  std::filesystem::remove_all(dir_template);
}

TEST(Spawn, FdLayout_OnlyMappedFdsSurvive) {
  auto pair = SeqPacket::pair();
  ASSERT_TRUE(pair.has_value());
  SpawnSpec spec = probe("fd-count");
  spec.fds = {{3, pair->second.fd()}};
  EXPECT_EQ(exit_code_of(spec), 1);  // only fd 3: the pair's other end and the test's fds are gone
}

TEST(Spawn, FdLayout_ChildReadsMappedFd) {
  auto pair = SeqPacket::pair();
  ASSERT_TRUE(pair.has_value());
  const std::string hello = "hello";
  ASSERT_TRUE(pair->first.send(std::as_bytes(std::span(hello))).has_value());
  SpawnSpec spec = probe("fd3");
  spec.fds = {{3, pair->second.fd()}};
  EXPECT_EQ(exit_code_of(spec), 0);
}

TEST(ChildProcess, Destructor_KillsAndReaps) {
  pid_t pid = -1;
  {
    auto child = spawn(probe("sleep"));
    ASSERT_TRUE(child.has_value());
    pid = child->pid();
    EXPECT_TRUE(process_exists(pid));
    auto running = child->try_wait();
    ASSERT_TRUE(running.has_value());
    EXPECT_FALSE(running->has_value());
  }
  EXPECT_FALSE(process_exists(pid));  // neither running nor a zombie
}

TEST(ChildProcess, Signal_ReportedAsSignaled) {
  auto child = spawn(probe("sleep"));
  ASSERT_TRUE(child.has_value());
  ASSERT_TRUE(child->signal(SIGTERM).has_value());
  const auto status = child->wait();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->how, ExitStatus::How::Signaled);
  EXPECT_EQ(status->value, SIGTERM);
  EXPECT_EQ(status->to_string(), "killed by SIGTERM");
}

class Seccomp : public ::testing::Test {
 protected:
  void SetUp() override {
    auto p = SeccompProgram::service_policy(Enforcement::Standalone);
    ASSERT_TRUE(p.has_value()) << p.error().to_string();
    program_ = std::move(*p);
  }
  int run(std::string what) {
    SpawnSpec spec = probe(std::move(what));
    spec.seccomp = &program_;
    return exit_code_of(spec);
  }
  // A forbidden call never returns: the filter ends the process as if by SIGSYS, which its parent sees.
  ExitStatus status_of(std::string what) {
    SpawnSpec spec = probe(std::move(what));
    spec.seccomp = &program_;
    auto child = spawn(spec);
    EXPECT_TRUE(child.has_value()) << (child ? "" : child.error().to_string());
    if (!child) return {};
    auto status = child->wait();
    EXPECT_TRUE(status.has_value());
    return status.value_or(ExitStatus{});
  }
  static void expect_killed_by_sigsys(const ExitStatus& s) {
    EXPECT_EQ(s.how, ExitStatus::How::Signaled) << s.to_string();
    EXPECT_EQ(s.value, SIGSYS) << s.to_string();
  }
  SeccompProgram program_;
};

TEST_F(Seccomp, Socket_KillsTheProcess) { expect_killed_by_sigsys(status_of("socket")); }
TEST_F(Seccomp, UnixSocket_KillsTheProcess) { expect_killed_by_sigsys(status_of("unix-socket")); }
TEST_F(Seccomp, Socketpair_KillsTheProcess) { expect_killed_by_sigsys(status_of("socketpair")); }
TEST_F(Seccomp, Ptrace_KillsTheProcess) { expect_killed_by_sigsys(status_of("ptrace")); }
TEST_F(Seccomp, ProcessVmReadv_KillsTheProcess) { expect_killed_by_sigsys(status_of("process-vm-readv")); }
TEST_F(Seccomp, SignalToOtherProcess_KillsTheProcess) { expect_killed_by_sigsys(status_of("kill-parent")); }
TEST_F(Seccomp, SignalToSelf_Allowed) { EXPECT_EQ(run("kill-self"), 1); }

TEST_F(Seccomp, PlainFork_KillsTheProcess) { expect_killed_by_sigsys(status_of("fork")); }
TEST_F(Seccomp, CloneWithImageForkFlags_Allowed) { EXPECT_EQ(run("clone-parent"), 1); }
TEST_F(Seccomp, CloneNewUser_KillsTheProcess) { expect_killed_by_sigsys(status_of("clone-newuser")); }
TEST_F(Seccomp, Thread_AllowedThroughCloneFallback) { EXPECT_EQ(run("thread"), 1); }
TEST_F(Seccomp, IoUringSetup_KillsTheProcess) { expect_killed_by_sigsys(status_of("io-uring")); }
TEST_F(Seccomp, Tiocsti_KillsTheProcess) { expect_killed_by_sigsys(status_of("tiocsti")); }
TEST_F(Seccomp, Setsid_KillsTheProcess) { expect_killed_by_sigsys(status_of("setsid")); }
TEST_F(Seccomp, UnshareNet_KillsTheProcess) { expect_killed_by_sigsys(status_of("unshare-net")); }
TEST_F(Seccomp, SetAffinity_KillsTheProcess) { expect_killed_by_sigsys(status_of("affinity")); }
// SIGIO aims a signal at a process group or a uid (its images, the kernel): no owner, no signal, no O_ASYNC.
TEST_F(Seccomp, FcntlSetown_KillsTheProcess) { expect_killed_by_sigsys(status_of("fcntl-setown")); }
TEST_F(Seccomp, FcntlSetsig_KillsTheProcess) { expect_killed_by_sigsys(status_of("fcntl-setsig")); }
TEST_F(Seccomp, FcntlAsync_KillsTheProcess) { expect_killed_by_sigsys(status_of("fcntl-async")); }
TEST_F(Seccomp, FcntlNonblocking_Allowed) { EXPECT_EQ(run("fcntl-nonblock"), 1); }

// Firecracker's check: every system call outside the allow-list is refused (each in a fresh child, with
// all-zero arguments; the filter decides on the number before anything runs).
TEST_F(Seccomp, EveryCallOutsideTheAllowList_KillsTheProcess) {
  std::vector<int> allowed;
  for (const SyscallRule& r : service_syscalls()) {
    if (const auto nr = syscall_number(r.name)) allowed.push_back(*nr);
  }
  int refused = 0;
  for (int nr = 0; nr < 470; ++nr) {
    if (std::find(allowed.begin(), allowed.end(), nr) != allowed.end()) continue;
    if (syscall_name(nr).starts_with("syscall ")) continue;  // no such call on this architecture
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      std::vector<sock_filter> scratch(program_.scratch_size());
      int listener = -1;
      if (program_.install_in_child(scratch.data(), ::getpid(), &listener) != 0) ::_exit(2);
      ::syscall(nr, 0, 0, 0, 0, 0, 0);
      ::_exit(0);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGSYS) << syscall_name(nr) << " was not refused";
    ++refused;
  }
  EXPECT_GT(refused, 250);  // x86-64 has ≈ 360 calls; the list allows about 90
}

TEST(SeccompTable, EveryEntryNamesACallAndAReason) {
  for (const SyscallRule& r : service_syscalls()) {
    EXPECT_TRUE(syscall_number(r.name).has_value()) << r.name;
    EXPECT_FALSE(r.reason.empty()) << r.name;
  }
}

// No trusted boot phase: the boot calls' arguments are checked by the kernel too — an open only
// for reading, prlimit64 only to read its own limits, prctl only the SDK's non-dumpable switch. A failed check
// is RefusedAtBoot (EPERM, counted), not a boot call.
TEST(SeccompTable, Classify_BootCallArguments) {
  const auto call = [](std::string_view name, std::array<std::uint64_t, 6> args, pid_t tgid = 4242) {
    return SeccompNotice{.id = 1, .pid = tgid, .tgid = tgid, .nr = *syscall_number(name), .args = args};
  };
  EXPECT_EQ(classify(call("openat", {static_cast<std::uint64_t>(AT_FDCWD), 0, O_RDONLY | O_CLOEXEC, 0, 0, 0})),
            NoticeKind::BootCall);
  EXPECT_EQ(classify(call("openat", {0, 0, O_RDONLY | O_DIRECTORY | O_NONBLOCK, 0, 0, 0})), NoticeKind::BootCall);
  // /proc/self/fd/4 reopened for writing: the time page attack.
  EXPECT_EQ(classify(call("openat", {0, 0, O_RDWR | O_CLOEXEC, 0, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("openat", {0, 0, O_WRONLY, 0, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("openat", {0, 0, O_RDONLY | O_CREAT, 0600, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("openat", {0, 0, O_RDONLY | O_TRUNC, 0, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("openat", {0, 0, O_TMPFILE | O_RDWR, 0600, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("open", {0, O_RDONLY, 0, 0, 0, 0})), NoticeKind::BootCall);
  EXPECT_EQ(classify(call("open", {0, O_WRONLY | O_APPEND, 0, 0, 0, 0})), NoticeKind::RefusedAtBoot);
  // prlimit64(pid, resource, new, old): the C library reads its own stack limit; nothing else.
  EXPECT_EQ(classify(call("prlimit64", {0, RLIMIT_STACK, 0, 0x7000, 0, 0})), NoticeKind::BootCall);
  EXPECT_EQ(classify(call("prlimit64", {4242, RLIMIT_STACK, 0, 0x7000, 0, 0})), NoticeKind::BootCall);
  EXPECT_EQ(classify(call("prlimit64", {1, RLIMIT_CPU, 0x7000, 0, 0, 0})), NoticeKind::RefusedAtBoot);  // the kernel
  EXPECT_EQ(classify(call("prlimit64", {1, RLIMIT_CPU, 0, 0x7000, 0, 0})), NoticeKind::RefusedAtBoot);  // even reading
  EXPECT_EQ(classify(call("prlimit64", {0, RLIMIT_AS, 0x7000, 0, 0, 0})), NoticeKind::RefusedAtBoot);   // a new limit
  // prctl beyond the running service's options: only PR_SET_DUMPABLE 0 while booting.
  EXPECT_EQ(classify(call("prctl", {PR_SET_DUMPABLE, 0, 0, 0, 0, 0})), NoticeKind::BootCall);
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define REJUV_TEST_SANITIZED 1
#endif
#endif
#if !defined(REJUV_TEST_SANITIZED) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  // (a sanitizer build admits whatever prctl its runtime asks at start: seccomp.cpp boot_prctl)
  EXPECT_EQ(classify(call("prctl", {PR_SET_DUMPABLE, 1, 0, 0, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("prctl", {PR_SET_PDEATHSIG, 0, 0, 0, 0, 0})), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(call("prctl", {PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0, 0})), NoticeKind::RefusedAtBoot);
#endif
  EXPECT_EQ(classify(call("execveat", {3, 0, 0, 0, AT_EMPTY_PATH, 0})), NoticeKind::RefusedAtBoot);
}

// What the kernel's look at a booting open accepts (landlock.hpp path_within): beneath a rule, lexically.
TEST(Landlock, PathWithin_TheRulesLexically) {
  const auto rules = service_landlock_rules("/opt/svc/bin/my_service");
  EXPECT_TRUE(path_within(rules, "/usr/lib/x86_64-linux-gnu/libc.so.6", 77));
  EXPECT_TRUE(path_within(rules, "/lib/x86_64-linux-gnu/libm.so.6", 77));
  EXPECT_TRUE(path_within(rules, "/etc/ld.so.cache", 77));
  EXPECT_TRUE(path_within(rules, "/opt/svc/bin/my_service", 77));
  EXPECT_TRUE(path_within(rules, "/proc/self/maps", 77));
  EXPECT_TRUE(path_within(rules, "/proc/77/maps", 77));
  EXPECT_FALSE(path_within(rules, "/proc/1/cmdline", 77));       // another process (the kernel)
  EXPECT_FALSE(path_within(rules, "/proc/777/maps", 77));        // a prefix of digits is not its own
  EXPECT_FALSE(path_within(rules, "/opt/svc/bin/my_service.key", 77));
  EXPECT_FALSE(path_within(rules, "/opt/svc/bin/launch.pbtxt", 77));
  EXPECT_FALSE(path_within(rules, "/usr/lib/../../etc/shadow", 77));
  EXPECT_FALSE(path_within(rules, "/usr/lib/./x", 77));
  EXPECT_FALSE(path_within(rules, "/usr/libexec/x", 77));        // not beneath /usr/lib
  EXPECT_FALSE(path_within(rules, "/etc/ld.so.cache.d/x", 77));
  EXPECT_FALSE(path_within(rules, "usr/lib/libc.so.6", 77));     // relative
  EXPECT_FALSE(path_within(rules, "", 77));
  EXPECT_FALSE(path_within(rules, "/etc/passwd", 77));
}

// Landlock by effect, in a child restricted like a service (no filter): it reads the libraries and its own
// /proc, and nothing else — not a file of its own user, not another process's /proc; it writes nothing.
TEST(Landlock, RestrictedChild_ReadsOnlyItsRules) {
  if (landlock_abi() == 0) GTEST_SKIP() << "Landlock is not enabled on this kernel";
  char dir_template[] = "/tmp/rejuv_landlock_XXXXXX";
  ASSERT_NE(::mkdtemp(dir_template), nullptr);
  const std::string secret = std::string(dir_template) + "/secret";
  { std::ofstream(secret) << "the key"; }
  const auto rules = service_landlock_rules("/bin/true");
  const int abi = landlock_abi();
  const std::string kernel_proc = "/proc/" + std::to_string(::getpid()) + "/cmdline";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (restrict_in_child(rules, abi) != 0) ::_exit(10);
    const auto opens = [](const char* p, int flags) {
      const int fd = ::open(p, flags | O_CLOEXEC, 0600);
      if (fd >= 0) ::close(fd);
      return fd >= 0;
    };
    if (!opens("/etc/ld.so.cache", O_RDONLY)) ::_exit(11);
    if (!opens("/proc/self/maps", O_RDONLY)) ::_exit(12);
    if (opens(secret.c_str(), O_RDONLY)) ::_exit(13);
    if (opens(kernel_proc.c_str(), O_RDONLY)) ::_exit(14);
    if (opens("/etc/passwd", O_RDONLY)) ::_exit(15);
    if (opens((secret + ".new").c_str(), O_WRONLY | O_CREAT)) ::_exit(16);
    if (abi >= 6 && ::kill(::getppid(), 0) == 0) ::_exit(17);  // scoped: no signal out of the domain
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10 restrict, 11 ld.so.cache refused, 12 /proc/self refused, 13 a file of "
                                       "its user read, 14 another /proc read, 15 /etc read, 16 a file made, "
                                       "17 a signal out of its domain";
  EXPECT_FALSE(std::filesystem::exists(secret + ".new"));
  std::filesystem::remove_all(dir_template);
}

TEST(SeccompTable, DocsSandboxListsEveryEntry) {
  std::ifstream doc(std::string(REJUV_SOURCE_DIR) + "/docs/sandbox.md");
  ASSERT_TRUE(doc.good());
  std::stringstream buffer;
  buffer << doc.rdbuf();
  const std::string text = buffer.str();
  for (const SyscallRule& r : service_syscalls()) {
    const std::string when = r.allowance == Allowance::Always ? "always" : r.allowance == Allowance::WhileBooting ? "until Ready" : "ENOSYS";
    EXPECT_NE(text.find("| `" + std::string(r.name) + "` | " + when + " |"), std::string::npos)
        << "docs/sandbox.md does not list " << r.name << " as '" << when << "'";
  }
}

TEST(SeccompTable, Classify_BootCallsAndForbiddenCalls) {
  const auto notice = [](std::string_view name, std::uint64_t arg2 = 0) {
    return SeccompNotice{.id = 1, .pid = 1, .nr = *syscall_number(name), .args = {0, 0, arg2, 0, 0, 0}};
  };
  EXPECT_EQ(classify(notice("openat")), NoticeKind::BootCall);
  // The kernel's exec of the binary is let through by the spawner (await_exec): one the service makes is not.
  EXPECT_EQ(classify(notice("execve")), NoticeKind::RefusedAtBoot);
  EXPECT_EQ(classify(notice("mmap", PROT_EXEC)), NoticeKind::BootCall);
  EXPECT_EQ(classify(notice("socket")), NoticeKind::Forbidden);
  EXPECT_EQ(classify(notice("io_uring_setup")), NoticeKind::Forbidden);
  EXPECT_EQ(classify(notice("clone")), NoticeKind::Forbidden);  // flags other than the image fork's
  EXPECT_EQ(classify(notice("ioctl")), NoticeKind::Forbidden);  // a code outside the list (TIOCSTI …)
  EXPECT_EQ(syscall_name(*syscall_number("io_uring_enter")), "io_uring_enter");
  // fcntl: nothing that aims a signal (the owner of SIGIO, its signal, leases, O_ASYNC).
  const auto fcntl_notice = [&](std::uint64_t cmd, std::uint64_t arg) {
    return SeccompNotice{.id = 1, .pid = 1, .tgid = 1, .nr = *syscall_number("fcntl"), .args = {3, cmd, arg, 0, 0, 0}};
  };
  EXPECT_EQ(classify(fcntl_notice(F_SETOWN, 0)), NoticeKind::Forbidden);
  EXPECT_EQ(classify(fcntl_notice(F_SETSIG, SIGKILL)), NoticeKind::Forbidden);
  EXPECT_EQ(classify(fcntl_notice(F_SETFL, O_ASYNC)), NoticeKind::Forbidden);
  // Signals: to the caller's own process only, whatever pid it has (a restored image has a new one), from
  // any of its threads (the notice names the thread; raise() from a worker targets the process).
  SeccompNotice self = notice("kill");
  self.pid = 4242;
  self.tgid = 4242;
  self.args[0] = 4242;
  EXPECT_EQ(classify(self), NoticeKind::SignalToSelf);
  SeccompNotice from_worker = notice("tgkill");
  from_worker.pid = 4250;  // a worker thread of process 4242
  from_worker.tgid = 4242;
  from_worker.args[0] = 4242;
  from_worker.args[1] = 4250;
  EXPECT_EQ(classify(from_worker), NoticeKind::SignalToSelf);
  self.args[0] = 4243;
  EXPECT_EQ(classify(self), NoticeKind::Forbidden);
  self.args[0] = static_cast<std::uint64_t>(-1);  // every process it may signal
  EXPECT_EQ(classify(self), NoticeKind::Forbidden);
}

// The supervised form: the kernel's. Boot calls are referred to the supervisor, which lets them continue
// until the process says it is ready; afterwards the same call is a violation the supervisor sees by name.
class SeccompSupervised : public ::testing::Test {
 protected:
  void SetUp() override {
    auto p = SeccompProgram::service_policy(Enforcement::Supervised);
    ASSERT_TRUE(p.has_value()) << p.error().to_string();
    program_ = std::move(*p);
  }
  // Runs the probe, allowing boot calls until it writes "ready" (then tells it so on its stdin); returns
  // the name of the first call refused after that (the probe is killed then), or "" if it exited.
  std::string first_violation(std::string what) {
    auto out = make_pipe();
    std::array<int, 2> in{-1, -1};
    EXPECT_TRUE(out.has_value() && ::pipe2(in.data(), O_CLOEXEC) == 0);
    UniqueFd in_read(in[0]);
    UniqueFd in_write(in[1]);
    SpawnSpec spec = probe(std::move(what));
    spec.seccomp = &program_;
    spec.fds = {{0, in_read.get()}, {1, out->write.get()}};
    auto spawned = spawn_supervised(spec);
    EXPECT_TRUE(spawned.has_value()) << (spawned ? "" : spawned.error().to_string());
    if (!spawned) return "spawn failed";
    out->write.reset();
    in_read.reset();
    bool ready = false;
    std::string violation;
    for (int i = 0; i < 20000 && violation.empty(); ++i) {
      std::array<char, 64> buf{};
      if (auto n = read_some(out->read.get(), buf); n && *n && **n > 0 && !ready) {
        ready = std::string_view(buf.data(), **n).find("ready") != std::string_view::npos;
        if (ready) {
          EXPECT_EQ(::write(in_write.get(), "y", 1), 1);
        }
      }
      auto notice = spawned->listener.receive();
      EXPECT_TRUE(notice.has_value());
      if (notice && *notice) {
        const NoticeKind kind = classify(**notice);
        if ((!ready && kind == NoticeKind::BootCall) || kind == NoticeKind::SignalToSelf) {
          EXPECT_TRUE(spawned->listener.allow((*notice)->id).has_value());
        } else {
          violation = syscall_name((*notice)->nr);
          EXPECT_TRUE(signal_if((*notice)->pid, SIGKILL, [&] { return spawned->listener.still_waiting((*notice)->id); }));
        }
      }
      if (auto st = spawned->process.try_wait(); st && *st) break;
      ::usleep(100);
    }
    spawned->process.kill_and_reap();
    return violation;
  }
  SeccompProgram program_;
};

TEST_F(SeccompSupervised, Socket_ReportedByName) { EXPECT_EQ(first_violation("socket"), "socket"); }
TEST_F(SeccompSupervised, IoUring_ReportedByName) { EXPECT_EQ(first_violation("io-uring"), "io_uring_setup"); }
TEST_F(SeccompSupervised, OpenAfterReady_IsAViolation) { EXPECT_EQ(first_violation("open-after-ready"), "openat"); }
TEST_F(SeccompSupervised, SignalToSelf_NoViolation) { EXPECT_EQ(first_violation("kill-self"), ""); }

// ---- isolation and limits (spawn) ----

TEST(Isolation, ReadOnlyMounts_NoFileIsWritten) {
  const std::string path = "/tmp/rejuv-isolation-probe-" + std::to_string(::getpid());
  SpawnSpec spec = probe("write-file");
  spec.args.push_back(path);
  spec.isolation = Isolation::Namespaces;
  auto child = spawn(spec);
  if (!child && (child.error().call.starts_with("unshare") || child.error().call.starts_with("read-only"))) {
    GTEST_SKIP() << "no namespaces here: " << child.error().to_string();
  }
  ASSERT_TRUE(child.has_value()) << child.error().to_string();
  const auto status = child->wait();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->value, 0) << "the probe could write " << path;  // 0: EROFS
  EXPECT_FALSE(std::filesystem::exists(path));
  std::filesystem::remove(path);
}

TEST(Isolation, WithoutNamespaces_TheFileIsWritten) {  // the counterpart: the probe really writes
  const std::string path = "/tmp/rejuv-isolation-probe-b-" + std::to_string(::getpid());
  SpawnSpec spec = probe("write-file");
  spec.args.push_back(path);
  EXPECT_EQ(exit_code_of(spec), 1);
  EXPECT_TRUE(std::filesystem::exists(path));
  std::filesystem::remove(path);
}

TEST(Isolation, ResourceLimits_Applied) {
  SpawnSpec spec = probe("rlimit-files");
  spec.limits.open_files = 37;
  EXPECT_EQ(exit_code_of(spec), 37);
}

TEST(SeccompBaseline, WithoutFilter_ActionsAllowed) {
  // The probe really does the actions: without the filter they succeed (so the tests above can fail).
  EXPECT_EQ(exit_code_of(probe("socket")), 1);
  EXPECT_EQ(exit_code_of(probe("kill-parent")), 1);
  EXPECT_EQ(exit_code_of(probe("socketpair")), 1);
}

TEST(Subreaper, CountChildren_SeesSpawnedProcess) {
  const auto before = count_children(::getpid());
  ASSERT_TRUE(before.has_value());
  auto child = spawn(probe("sleep"));
  ASSERT_TRUE(child.has_value());
  EXPECT_EQ(count_children(::getpid()).value(), *before + 1);
  child->kill_and_reap();
  EXPECT_EQ(count_children(::getpid()).value(), *before);
}


// ---- CPU placement (KernelOptions::placement, docs/design.md §6) ----

// Runs `body` in a thread of its own, so that pinning it leaves the test process's mask alone.
template <class F>
void in_thread(F body) {
  std::thread t(body);
  t.join();
}

std::string cpus_allowed_list(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Cpus_allowed_list:", 0) == 0) return line.substr(line.find_first_not_of(" \t", 18));
  }
  return {};
}

// The calling thread's CPU mask, ascending (what the kernel's pin leaves it with).
std::vector<int> thread_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  EXPECT_EQ(::sched_getaffinity(0, sizeof(set), &set), 0);
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &set)) cpus.push_back(c);
  }
  return cpus;
}

TEST(CpuPlacement, PinToOneCpu_OnlyThatCpuAllowedAndInherited) {
  in_thread([] {
    const std::vector<int> before = thread_cpus();
    ASSERT_FALSE(before.empty());
    const int want = before.back();
    auto pinned = pin_to_one_cpu(want);
    ASSERT_TRUE(pinned.has_value()) << pinned.error().to_string();
    EXPECT_EQ(*pinned, want);
    EXPECT_EQ(thread_cpus(), std::vector<int>{want});
    // A process spawned from the pinned thread inherits the mask (the services and the plant do).
    auto child = spawn(probe("sleep"));
    ASSERT_TRUE(child.has_value()) << child.error().to_string();
    EXPECT_EQ(cpus_allowed_list(child->pid()), std::to_string(want));
  });
}

TEST(CpuPlacement, PinToOneCpu_Current_OnlyThatCpuAllowed) {
  in_thread([] {
    auto pinned = pin_to_one_cpu(std::nullopt);
    ASSERT_TRUE(pinned.has_value()) << pinned.error().to_string();
    EXPECT_EQ(thread_cpus(), std::vector<int>{*pinned});
  });
}

TEST(CpuPlacement, PinToOneCpu_OutOfRange_EinvalAsValueMaskUnchanged) {
  in_thread([] {
    const std::vector<int> before = thread_cpus();
    auto r = pin_to_one_cpu(CPU_SETSIZE);
    ASSERT_FALSE(r.has_value());
    EXPECT_EQ(r.error().error, EINVAL);
    auto negative = pin_to_one_cpu(-1);
    ASSERT_FALSE(negative.has_value());
    EXPECT_EQ(negative.error().error, EINVAL);
    EXPECT_EQ(thread_cpus(), before);
  });
}

// lower_priority (nice 19 before a kill) is gone: the kernel kills at the victim's own priority. What it
// asserted, a priority read back from the process, is asserted of the pair the kernel uses instead.
TEST(CpuPlacement, IdleThenNormalPriority_ReadBackFromTheProcess) {
  auto child = spawn(probe("sleep"));
  ASSERT_TRUE(child.has_value()) << child.error().to_string();
  ASSERT_TRUE(idle_priority(child->pid()).has_value());
  EXPECT_EQ(::sched_getscheduler(child->pid()), SCHED_IDLE);
  ASSERT_TRUE(::setpriority(PRIO_PROCESS, static_cast<id_t>(child->pid()), 19) == 0);
  ASSERT_TRUE(normal_priority(child->pid()).has_value());
  EXPECT_EQ(::sched_getscheduler(child->pid()), SCHED_OTHER);
  errno = 0;
  EXPECT_EQ(::getpriority(PRIO_PROCESS, static_cast<id_t>(child->pid())), 0);
  EXPECT_EQ(errno, 0);
}

TEST(CpuPlacement, NormalPriority_NoSuchProcess_ErrorValue) {
  auto r = normal_priority(0x3FFFFFFF);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().error, ESRCH);
}

}  // namespace
}  // namespace rejuv::sys

// The pid fallback when no pidfd can be opened: only a child of this process is signalled, and it is reaped.
TEST(Process, KillAndReapOwnChild_KillsAChildAndLeavesOthersAlone) {
  const pid_t child = ::fork();
  if (child == 0) {
    ::pause();
    ::_exit(0);
  }
  ASSERT_GT(child, 0);
  EXPECT_FALSE(rejuv::sys::kill_and_reap_own_child(::getppid()));  // not a child: nothing signalled
  EXPECT_EQ(::kill(::getppid(), 0), 0);
  EXPECT_TRUE(rejuv::sys::kill_and_reap_own_child(child));
  EXPECT_EQ(::kill(child, 0), -1) << "killed and reaped: the pid names nothing";
  EXPECT_EQ(errno, ESRCH);
  EXPECT_FALSE(rejuv::sys::kill_and_reap_own_child(child));
}

// ---- What the scheduler gave a thread (sys::task_cpu, the liveness watch's "waiting for a CPU") ----

namespace {
// A child that spins on CPU 0 until killed.
pid_t spinner_on_cpu0() {
  const pid_t pid = ::fork();
  if (pid == 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(0, &set);
    (void)::sched_setaffinity(0, sizeof(set), &set);
    std::atomic<std::uint64_t> spins{0};
    for (;;) spins.fetch_add(1, std::memory_order_relaxed);
  }
  return pid;
}
}  // namespace

// Three spinners on one CPU: each is runnable the whole time (running or waiting for the CPU) and runs; a stopped
// one is not runnable and does not run.
TEST(TaskCpu, SpinnerRunnableAndRuns_StoppedNeither) {
  std::array<pid_t, 3> spinners{spinner_on_cpu0(), spinner_on_cpu0(), spinner_on_cpu0()};
  for (const pid_t p : spinners) ASSERT_GT(p, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds{50});
  const auto before = rejuv::sys::task_cpu(spinners[0]);
  std::this_thread::sleep_for(std::chrono::milliseconds{300});
  const auto after = rejuv::sys::task_cpu(spinners[0]);
  ASSERT_TRUE(before.has_value()) << before.error().to_string();
  ASSERT_TRUE(after.has_value()) << after.error().to_string();
  EXPECT_GT(after->ran, before->ran) << "it ran";
  EXPECT_TRUE(before->runnable);
  EXPECT_TRUE(after->runnable);

  ASSERT_EQ(::kill(spinners[1], SIGSTOP), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds{50});
  const auto stopped = rejuv::sys::task_cpu(spinners[1]);
  std::this_thread::sleep_for(std::chrono::milliseconds{200});
  const auto still = rejuv::sys::task_cpu(spinners[1]);
  ASSERT_TRUE(stopped.has_value());
  ASSERT_TRUE(still.has_value());
  EXPECT_FALSE(still->runnable) << "stopped";
  EXPECT_EQ(still->ran, stopped->ran) << "a stopped process does not run";
  for (const pid_t p : spinners) {
    (void)::kill(p, SIGKILL);
    (void)::waitpid(p, nullptr, 0);
  }
  EXPECT_FALSE(rejuv::sys::task_cpu(spinners[0]).has_value()) << "gone: an error, not a value";
  const auto self = rejuv::sys::task_cpu(::getpid());
  ASSERT_TRUE(self.has_value());
  EXPECT_TRUE(self->runnable) << "the caller runs";
}

// Runnable as the load average counts it: a process in an uninterruptible wait inside the OS (D: here a vfork
// parent until its child exits) waits on the machine, and one asleep by its own call (S: pause) does not.
TEST(TaskCpu, InAnOsWaitRunnable_AsleepNot) {
  const pid_t waiting = ::fork();
  if (waiting == 0) {
    if (::vfork() == 0) {
      const timespec second{.tv_sec = 1, .tv_nsec = 0};
      (void)::nanosleep(&second, nullptr);
      ::_exit(0);
    }
    ::_exit(0);
  }
  const pid_t asleep = ::fork();
  if (asleep == 0) {
    for (;;) ::pause();
  }
  ASSERT_GT(waiting, 0);
  ASSERT_GT(asleep, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds{200});
  const auto in_os = rejuv::sys::task_cpu(waiting);
  const auto slept = rejuv::sys::task_cpu(asleep);
  (void)::kill(asleep, SIGKILL);
  (void)::waitpid(asleep, nullptr, 0);
  int status = 0;
  ASSERT_EQ(::waitpid(waiting, &status, 0), waiting);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the vfork parent went on once its child exited";
  ASSERT_TRUE(in_os.has_value()) << in_os.error().to_string();
  ASSERT_TRUE(slept.has_value()) << slept.error().to_string();
  EXPECT_EQ(in_os->state, 'D');
  EXPECT_TRUE(in_os->runnable) << "waiting for its vfork child inside the OS";
  EXPECT_EQ(slept->state, 'S');
  EXPECT_FALSE(slept->runnable) << "asleep in pause";
}
