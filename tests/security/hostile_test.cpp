// The hostile-service suite (docs/design.md §7 "Protection (containment)"): the worker of the security
// graph (security_launch.hpp) is compromised and tries one escape (services/escapes.cpp), at boot (after
// connect, before Ready: boot calls such as open still pass, so the namespaces and limits must hold) or at its
// first tick of each MC window. The service is spawned by the real kernel spawn path (allow-list filter with
// the kernel as supervisor, namespaces, its own uid as root, resource limits), lockstep driven by the test,
// SR on.
//
// Each attempt is judged by its effect — no datagram reached the test's UDP listener, no file exists, the
// test's victim process lives, the kernel's memory and tracer are untouched, no helper process outlives the
// next sweep, nothing unattributed in the kernel log — and by the kernel's count (calls_refused names the
// call, or stray_processes), and the run goes on (rolled back, no stop reason). After each test no process of
// the worker's session is left. No timing is asserted.
#include <arpa/inet.h>
#include <dirent.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "graph_fixture.hpp"
#include "mission_support.hpp"
#include "rejuv/sys/sanitizer.hpp"
#include "security_launch.hpp"
#include "services/verdicts.hpp"

namespace rejuv::testing {
namespace {

namespace verdicts = test_services::verdicts;
constexpr double kNotTried = -1000;  // escapes::kNotTried
constexpr std::string_view escapes_mark = "FAKE-KERNEL-ULOG";  // escapes::kForgedMark
constexpr std::uint64_t kCanaryValue = 0x5AFE'5AFE'5AFE'5AFEULL;
volatile std::uint64_t g_canary = kCanaryValue;  // NOLINT: process_vm_writev's target in the kernel (this process)

using mission::session_members;  // this process's descendants only: another test's pid may reuse a sid

// Whether `pid` is a living process (a zombie is dead: its parent, the kernel, reaps it at its next sweep).
bool living(pid_t pid) { return mission::proc_stat(pid).living(); }

std::string status_field(pid_t pid, const std::string& field) {
  std::ifstream in(pid == 0 ? std::string("/proc/self/status") : "/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(field + ":", 0) == 0) {
      std::string v = line.substr(field.size() + 1);
      v.erase(0, v.find_first_not_of(" \t"));
      return v;
    }
  }
  return "";
}

std::string limits_line(pid_t pid, const std::string& name) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/limits");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(name, 0) == 0) return line;
  }
  return "";
}

// A loopback UDP listener the test owns: an escaped service would send it a datagram.
class UdpListener {
 public:
  UdpListener() : fd_(::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (fd_.get() < 0 || ::bind(fd_.get(), reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||  // NOLINT
        ::getsockname(fd_.get(), reinterpret_cast<sockaddr*>(&a), &len) != 0) {             // NOLINT
      ADD_FAILURE() << "udp listener: " << std::strerror(errno);
      return;
    }
    port_ = ntohs(a.sin_port);
  }
  [[nodiscard]] std::uint16_t port() const { return port_; }
  // Datagrams waiting (receive timeout 0: asked after the run).
  [[nodiscard]] int pending() const {
    int n = 0;
    std::array<char, 256> buf{};
    while (::recv(fd_.get(), buf.data(), buf.size(), MSG_DONTWAIT) >= 0) ++n;
    return n;
  }

 private:
  sys::UniqueFd fd_;
  std::uint16_t port_ = 0;
};

// A process of the test's own that the worker tries to kill; killed and reaped on destruction.
class Victim {
 public:
  Victim() : pid_(::fork()) {
    if (pid_ == 0) {
      for (;;) ::pause();  // async-signal-safe only: this process has threads (DDS)
    }
  }
  Victim(const Victim&) = delete;
  Victim& operator=(const Victim&) = delete;
  ~Victim() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] bool alive() const { return pid_ > 0 && ::waitpid(pid_, nullptr, WNOHANG) == 0; }

 private:
  pid_t pid_;
};

// The kernel log, captured (KernelOptions::log) to find lines no one signed.
class CapturedLog {
 public:
  CapturedLog() : file_(::open_memstream(&buf_, &size_)) {}
  CapturedLog(const CapturedLog&) = delete;
  CapturedLog& operator=(const CapturedLog&) = delete;
  ~CapturedLog() {
    if (file_ != nullptr) std::fclose(file_);
    std::free(buf_);  // NOLINT(cppcoreguidelines-no-malloc): open_memstream's buffer
  }
  [[nodiscard]] std::FILE* file() const { return file_; }
  [[nodiscard]] std::vector<std::string> lines() const {
    std::fflush(file_);
    std::vector<std::string> out;
    std::istringstream in(std::string(buf_, size_));
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
  }

 private:
  char* buf_ = nullptr;
  std::size_t size_ = 0;
  std::FILE* file_;
};

// The log lines the kernel hands its observers (the ULog recorder writes each as "<source>: <text>", docs/ulog.md).
class LogLines final : public kernel::Observer {
 public:
  void on_log(const kernel::LogLine& line) override { lines.emplace_back(std::string(line.source), std::string(line.text)); }
  std::vector<std::pair<std::string, std::string>> lines;  // source, text
};

struct Escape {
  std::string name;          // escapes.cpp's table
  std::string at = "mc";     // "boot" | "mc"
  std::string params{};      // more `params { … }` of the worker
  std::string limits{};      // the worker's `limits { … }`
};

class Hostile : public ::testing::Test {
 protected:
  void TearDown() override {
    k_.reset();  // shutdown: the kernel kills and reaps what it knows and sweeps the sessions
    if (worker_sid_ > 0) {
      const auto left = session_members(worker_sid_);
      EXPECT_TRUE(left.empty()) << left.size() << " process(es) of the worker's session left after shutdown, first "
                                << left.front();
      for (const pid_t pid : left) ::kill(pid, SIGKILL);  // processes this test's kernel spawned
    }
    for (const auto& f : files_) std::filesystem::remove(f);
    if (std::getenv("REJUV_TEST_LOG") != nullptr) {
      for (const auto& l : log_.lines()) std::fprintf(stderr, "%s\n", l.c_str());
    }
  }

  void start(const Escape& e) {
    escape_ = e;
    std::string extra = "  params { name: \"escape\" text: \"" + e.name + "\" }\n  params { name: \"escape_at\" text: \"" +
                        e.at + "\" }\n";
    extra += "  params { name: \"udp_port\" number: " + std::to_string(udp_.port()) + " }\n";
    extra += "  params { name: \"victim\" number: " + std::to_string(victim_.pid()) + " }\n";
    extra += "  params { name: \"address\" number: " +
             std::to_string(reinterpret_cast<std::uintptr_t>(&g_canary)) + " }\n";  // NOLINT: an address
    extra += e.params + e.limits;
    auto loaded = launch::parse_launch(security_launch({.worker_extra = extra, .attack = ""}),
                                       std::filesystem::path(REJUV_SOURCE_DIR) / "tests/security/graphs/hostile.launch.pbtxt");
    ASSERT_TRUE(loaded.has_value()) << loaded.error().to_string();
    kernel::KernelOptions o = test_options();
    o.log = log_.file();
    o.verbose = false;
    auto k = kernel::Kernel::create(std::move(*loaded), o, &observers_);
    ASSERT_TRUE(k.has_value()) << k.error().to_string() << "\n" << ::testing::PrintToString(k.error().findings);
    k_ = std::move(*k);
    auto booted = k_->boot();
    ASSERT_TRUE(booted.has_value()) << booted.error().to_string();
    const int pid = k_->stats(id("worker")).pid;
    ASSERT_GT(pid, 0);
    worker_sid_ = ::getsid(pid);
    ASSERT_EQ(worker_sid_, pid) << "the worker is not the leader of its own session";
    ASSERT_NE(worker_sid_, ::getsid(0));
  }
  std::string file_param(const std::string& dir) {
    const std::string path = dir + "/rejuv_hostile_" + std::to_string(::getpid()) + "_" + escape_.name;
    files_.push_back(path);
    std::filesystem::remove(path);
    return "  params { name: \"path\" text: \"" + path + "\" }\n";
  }

  ServiceId id(std::string_view name) const { return *k_->find_service(name); }
  [[nodiscard]] ::testing::AssertionResult step_until_rollbacks(std::uint64_t n, int limit = 600) {
    return testing::step_until_rollbacks(*k_, n, limit);
  }
  // What the worker reported of an escape that returned.
  std::vector<verdicts::EscapeReport> outcomes() const {
    std::vector<verdicts::EscapeReport> out;
    for (const Seen* s : recorder_.on("verdicts")) {
      const auto r = verdicts::decode<verdicts::EscapeReport>(Recorder::as<rejuv_msg_SensorBaro>(*s));
      if (r && s->publisher == id("worker")) out.push_back(*r);
    }
    return out;
  }
  std::uint64_t refused(std::string_view call) const {
    for (const auto& [name, n] : k_->stats(id("worker")).calls_refused) {
      if (name == call) return n;
    }
    return 0;
  }
  std::string refused_calls() const {
    std::string out;
    for (const auto& [name, n] : k_->stats(id("worker")).calls_refused) out += name + "×" + std::to_string(n) + " ";
    return out;
  }
  // The processes of the worker's session the kernel does not know (neither live nor an image).
  std::vector<pid_t> unknown_in_session() {
    std::vector<pid_t> known = k_->image_pids(id("worker"));
    known.push_back(k_->stats(id("worker")).pid);
    std::vector<pid_t> out;
    for (const pid_t pid : session_members(worker_sid_)) {
      if (std::find(known.begin(), known.end(), pid) == known.end()) out.push_back(pid);
    }
    return out;
  }

  // The effects no escape may have, whatever it was: the test's listener got nothing, no file was made, the
  // victim lives, the kernel's memory is as it was and no one traces it, no service line went unsigned, the
  // run goes on. (What is left of the worker's session is checked after shutdown, in TearDown: during the run
  // a killed incarnation may still be dying and a spare image not yet reported.)
  void expect_nothing_escaped() {
    EXPECT_EQ(udp_.pending(), 0) << "a datagram reached the test's listener";
    for (const auto& f : files_) EXPECT_FALSE(std::filesystem::exists(f)) << f << " was created";
    EXPECT_TRUE(victim_.alive()) << "the victim process was killed";
    EXPECT_EQ(g_canary, kCanaryValue) << "the kernel's memory was written";
    EXPECT_EQ(status_field(0, "TracerPid"), "0") << "the kernel is being traced";
    for (const auto& line : log_.lines()) {
      EXPECT_TRUE(line.rfind("[kernel ", 0) != 0 || line.find("FAKE-KERNEL-LINE") == std::string::npos)
          << "an unattributed line: " << line;
    }
    EXPECT_FALSE(k_->stop_reason().has_value()) << k_->stop_detail();
    EXPECT_EQ(k_->sr_stats().cold_restarts, 0U);
    EXPECT_TRUE(k_->stats(id("worker")).alive);
    EXPECT_TRUE(k_->stats(id("driver")).alive);
  }

  Escape escape_;
  UdpListener udp_;
  Victim victim_;
  CapturedLog log_;
  std::vector<std::string> files_;
  pid_t worker_sid_ = -1;
  Recorder recorder_;
  LogLines log_lines_;
  kernel::ObserverFanout observers_{{&recorder_, &log_lines_}};
  std::unique_ptr<kernel::Kernel> k_;
};

// ---- forbidden calls in MC: the call never returns, the kernel names it, the violation rolls back ----

struct ForbiddenCase {
  std::string label;   // the test's name
  std::string escape;
  std::string call;    // what calls_refused must name
  std::string params{};
  std::string file_dir{};  // a file the escape creates there
};

ForbiddenCase forbidden(std::string label, std::string escape, std::string call, std::string params = "",
                        std::string file_dir = "") {
  return ForbiddenCase{.label = std::move(label), .escape = std::move(escape), .call = std::move(call),
                       .params = std::move(params), .file_dir = std::move(file_dir)};
}

class ForbiddenInMc : public Hostile, public ::testing::WithParamInterface<ForbiddenCase> {};

TEST_P(ForbiddenInMc, KilledInTheCall_CountedByName_RolledBack_NothingEscaped) {
  const ForbiddenCase& c = GetParam();
  escape_.name = c.escape;
  std::string params = c.params;
  if (!c.file_dir.empty()) params += file_param(c.file_dir);
  ASSERT_NO_FATAL_FAILURE(start({.name = c.escape, .at = "mc", .params = params, .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(2));
  EXPECT_TRUE(outcomes().empty()) << "the forbidden call returned " << outcomes().front().value;
  EXPECT_GE(refused(c.call), 1U) << "refused: " << refused_calls();
  EXPECT_GE(k_->stats(id("worker")).forbidden_calls, 1U);
  EXPECT_LT(k_->sr_stats().timer_rollbacks, k_->sr_stats().rollbacks) << "no rollback by the violation";
  expect_nothing_escaped();
}

INSTANTIATE_TEST_SUITE_P(
    Hostile, ForbiddenInMc,
    ::testing::Values(
        forbidden("SocketAfInetSendto", "udp_send", "socket"),
        forbidden("Socketpair", "socketpair", "socketpair"),
        forbidden("IoUringSocket", "io_uring", "io_uring_setup"),
        forbidden("OpenEtcPasswd", "open_passwd", "openat"),
        forbidden("OpenKernelEnviron", "open_kernel_environ", "openat"),
        forbidden("CreateFileInTmp", "create_file", "openat", "", "/tmp"),
        forbidden("CreateFileInDevShm", "create_file", "openat", "", "/dev/shm"),
        forbidden("MemfdElfExecveat", "memfd_execveat", "execveat"),
        forbidden("ExecveBinSh", "exec_sh", "execve"),
        forbidden("MmapRwx", "mmap_rwx", "mmap"),
        forbidden("MprotectExec", "mprotect_exec", "mprotect"),
        forbidden("PtraceAttachKernel", "ptrace_kernel", "ptrace"),
        forbidden("ProcessVmReadvKernel", "vm_readv_kernel", "process_vm_readv"),
        forbidden("ProcessVmWritevKernel", "vm_writev_kernel", "process_vm_writev"),
        forbidden("KillOtherPid", "kill_other", "kill"),
        forbidden("TgkillOtherPid", "tgkill_other", "tgkill"),
        forbidden("LibcForkThenSetsid", "fork", "clone"),
        forbidden("CloneNewUser", "clone_newuser", "clone"),
        forbidden("UnshareNewUser", "unshare_newuser", "unshare"),
        forbidden("UnshareNewNet", "unshare_newnet", "unshare"),
        forbidden("Setns", "setns", "setns"),
        forbidden("SchedSetaffinity", "sched_setaffinity", "sched_setaffinity"),
        forbidden("RaiseRlimitAfterBoot", "raise_rlimit", "prlimit64"),
        forbidden("IoctlTiocstiFd0", "tiocsti", "ioctl", "  params { name: \"fd\" number: 0 }\n"),
        forbidden("IoctlTiocstiFd1", "tiocsti", "ioctl", "  params { name: \"fd\" number: 1 }\n"),
        forbidden("IoctlTiocstiFd2", "tiocsti", "ioctl", "  params { name: \"fd\" number: 2 }\n"),
        forbidden("Bpf", "bpf", "bpf"),
        forbidden("PerfEventOpen", "perf_event_open", "perf_event_open"),
        forbidden("Keyctl", "keyctl", "keyctl")),
    [](const ::testing::TestParamInfo<ForbiddenCase>& p) { return p.param.label; });

// ---- at boot: open passes only for reading what a start-up reads (docs/sandbox.md "No trusted boot phase");
// the read-only mounts, Landlock and the uid hold behind it ----

class CreateFileAtBoot : public Hostile, public ::testing::WithParamInterface<std::string> {};

// open(O_CREAT) at boot: refused by the kernel on its flags (EPERM), counted against the worker, which boots on;
// no file exists (the read-only mount and Landlock would refuse it too).
TEST_P(CreateFileAtBoot, RefusedAndCountedAtBoot_NoFile_RunGoesOn) {
  escape_.name = "create_file";
  ASSERT_NO_FATAL_FAILURE(
      start({.name = "create_file", .at = "boot", .params = file_param(GetParam()), .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(1));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  EXPECT_EQ(o.front().value, -EPERM) << "open(O_CREAT) in " << GetParam();
  EXPECT_GE(k_->stats(id("worker")).forbidden_calls, 1U) << "the refused boot call was not counted";
  EXPECT_NE(refused_calls().find("openat"), std::string::npos) << refused_calls();
  expect_nothing_escaped();
}

INSTANTIATE_TEST_SUITE_P(Hostile, CreateFileAtBoot, ::testing::Values("/tmp", "/dev/shm"),
                         [](const auto& p) { return p.param == "/tmp" ? "Tmp" : "DevShm"; });

TEST_F(Hostile, OpenKernelEnvironAtBoot_RefusedByTheUid) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "open_kernel_environ", .at = "boot", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(1));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  std::printf("open(/proc/<kernel>/environ) at boot: %g\n", o.front().value);
  EXPECT_LT(o.front().value, 0) << "the kernel's environment was opened (" << o.front().detail
                                << " bytes read)";
  expect_nothing_escaped();
}

TEST_F(Hostile, RaiseRlimitAtBoot_RefusedAndTheLimitsHold) {
#if defined(REJUV_TSAN)
  GTEST_SKIP()
      << "a ThreadSanitizer build sets no RLIMIT_AS (its runtime reserves nearly the whole address space)";
#endif
  ASSERT_NO_FATAL_FAILURE(start({.name = "raise_rlimit",
                                 .at = "boot",
                                 .params = "",
                                 .limits = "  limits { max_memory_mb: 1024 max_open_files: 64 }\n"}));
  ASSERT_TRUE(step_until_rollbacks(1));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  EXPECT_EQ(o.front().value, -EPERM) << "RLIMIT_AS raised";
  EXPECT_EQ(o.front().detail, -EPERM) << "RLIMIT_NOFILE raised";
  const int pid = k_->stats(id("worker")).pid;
  // In an AddressSanitizer build, on top of what its runtime reserves (sys::kSanitizerAddressSpace).
  EXPECT_NE(limits_line(pid, "Max address space")
                .find(std::to_string((1024ULL << 20U) + sys::kSanitizerAddressSpace)),
            std::string::npos)
      << limits_line(pid, "Max address space");
  EXPECT_NE(limits_line(pid, "Max open files").find("64"), std::string::npos) << limits_line(pid, "Max open files");
  expect_nothing_escaped();
}

// ---- processes: what the filter lets it make, the sweeps must end ----

// A helper made in MC is killed by the sweep of the rollback that ends the window (warden.cpp: after the
// timed part, once the copies asked for earlier have reported) and counted as a stray.
TEST_F(Hostile, HelperByImageFlags_GoneAfterTheNextRollbackAndCountedAsStray) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "helper", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(3));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "the worker never reported its helper";
  for (const auto& [rc, pid] : o) {
    EXPECT_GE(rc, 0) << "clone(CLONE_PARENT|SIGCHLD) refused";
    const auto p = static_cast<pid_t>(pid);
    EXPECT_TRUE(!living(p) || ::getsid(p) != worker_sid_) << "helper " << p << " alive";
  }
  EXPECT_GE(k_->stats(id("worker")).stray_processes, o.size());
  expect_nothing_escaped();
}

// What holds today: every helper is killed and counted by the kernel, at the latest at shutdown.
TEST_F(Hostile, HelperByImageFlags_KilledAndCountedAsStrayByShutdown) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "helper", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_nothing_escaped();
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "the worker never reported its helper";
  k_->shutdown();
  for (const auto& [rc, pid] : o) {
    EXPECT_GE(rc, 0) << "clone(CLONE_PARENT|SIGCHLD) refused";
    const auto p = static_cast<pid_t>(pid);
    EXPECT_TRUE(!living(p) || ::getsid(p) != worker_sid_) << "helper " << p << " alive";
  }
  EXPECT_GE(k_->stats(id("worker")).stray_processes, o.size());
}

TEST_F(Hostile, HelperCallsSetsid_KilledInTheCallAndCounted) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "helper_setsid", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(2));
  EXPECT_GE(refused("setsid"), 1U) << "refused: " << refused_calls();
  expect_nothing_escaped();
  const auto o = outcomes();
  for (const auto& [rc, pid] : o) {
    const auto p = static_cast<pid_t>(pid);
    EXPECT_FALSE(living(p) && ::getsid(p) == p) << "helper " << p << " alive in a session of its own";
  }
  k_->shutdown();
  for (const auto& [rc, pid] : o) EXPECT_FALSE(living(static_cast<pid_t>(pid))) << "helper " << pid;
}

// Every process of a bomb is killed by the sweep of the rollback that follows it, so the process limit it
// filled is free again for the next window and the images (which share the worker uid's RLIMIT_NPROC).
TEST_F(Hostile, ForkBomb_AllSweptAtTheNextRollbackAndTheRunGoesOn) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "fork_bomb", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(2));
  // What the kernel does not know now: the bomb of the window before, or a spare image not reported yet.
  const std::vector<pid_t> before = unknown_in_session();
  ASSERT_TRUE(step_until_rollbacks(3));
  std::vector<pid_t> known = k_->image_pids(id("worker"));
  known.push_back(k_->stats(id("worker")).pid);
  for (const pid_t p : before) {
    EXPECT_TRUE(!living(p) || std::find(known.begin(), known.end(), p) != known.end())
        << "process " << p << " of the worker's session outlived a rollback";
  }
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "the worker never reported its bomb";
  std::uint64_t made = 0;
  for (const auto& [n, first_error] : o) made += static_cast<std::uint64_t>(n);
  EXPECT_GE(k_->stats(id("worker")).stray_processes, made);
  EXPECT_EQ(k_->sr_stats().fallbacks, 0U);
  expect_nothing_escaped();
}

// What holds today: the bomb is bounded by RLIMIT_NPROC (as root), every process of it is killed and counted
// by shutdown, and the run goes on.
TEST_F(Hostile, ForkBomb_BoundedByTheProcessLimitAndKilledByShutdown) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "fork_bomb", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(3));
  expect_nothing_escaped();
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "the worker never reported its bomb";
  std::uint64_t made = 0;
  for (const auto& [n, first_error] : o) {
    made += static_cast<std::uint64_t>(n);
    std::printf("fork bomb: %g processes made, then %g\n", n, first_error);
    if (::geteuid() == 0) {
      // RLIMIT_NPROC counts the worker uid's processes, the live worker among them; the uid is this kernel's
      // alone (a leased block, sys/lease.hpp), so no other run's processes count against it.
      EXPECT_LT(n, launch::defaults::kSandboxProcesses) << "not bounded by RLIMIT_NPROC (max_processes)";
      EXPECT_EQ(first_error, -EAGAIN);
    }
  }
  k_->shutdown();
  EXPECT_GE(k_->stats(id("worker")).stray_processes, made);
}

// Signals only to itself, whatever pid it has: a restored image (another pid than the process the filter was
// installed in) that signals the first incarnation's pid is refused and counted (the kernel compares the
// target with the caller's own pid, seccomp.cpp ArgCheck::SelfPid).
TEST_F(Hostile, KillFirstIncarnationFromAnImage_Refused) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "kill_first_incarnation", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(3));
  for (const auto& [rc, pid] : outcomes()) {
    if (rc != kNotTried) ADD_FAILURE() << "kill(" << pid << ", 0) from a restored image returned " << rc;
  }
  EXPECT_GE(refused("kill"), 1U) << "refused: " << refused_calls();
  expect_nothing_escaped();
}

// ---- what it may do, bounded ----

TEST_F(Hostile, MemoryHog_TheAllocationFailsUnderTheLimit) {
#if defined(REJUV_TSAN)
  GTEST_SKIP()
      << "a ThreadSanitizer build sets no RLIMIT_AS (its runtime reserves nearly the whole address space)";
#endif
  ASSERT_NO_FATAL_FAILURE(start({.name = "memory_hog",
                                 .at = "mc",
                                 .params = "  params { name: \"hog_mb\" number: 1024 }\n",
                                 .limits = "  limits { max_memory_mb: 512 }\n"}));
  ASSERT_TRUE(step_until_rollbacks(2));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  for (const auto& [rc, mb] : o) EXPECT_EQ(rc, -ENOMEM) << mb << " MiB allocated over a 512 MiB limit";
  EXPECT_EQ(k_->stats(id("worker")).forbidden_calls, 0U) << refused_calls();
  expect_nothing_escaped();
}

TEST_F(Hostile, FakeKernelLines_EveryLineSignedByTheWorker) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "fake_log", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(2));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  EXPECT_GT(o.front().value, 0) << "nothing written";
  int fakes = 0;
  for (const auto& line : log_.lines()) {
    if (line.find("FAKE-KERNEL-LINE") == std::string::npos) continue;
    ++fakes;
    EXPECT_EQ(line.rfind("[worker] ", 0), 0U) << "not signed by the worker: " << line;
    for (const char ch : line) EXPECT_FALSE(static_cast<unsigned char>(ch) < 0x20 && ch != '\t') << line;
  }
  EXPECT_GE(fakes, 2 * 5) << "the kernel did not log the worker's output";
  EXPECT_GE(k_->stats(id("worker")).output_lines, 2U * 5U);
  expect_nothing_escaped();
}

// ---- the log and the channel, as a hostile service writes them ----

// Log frames and a publication whose bytes look like kernel log lines and ULog messages: every such line is the
// worker's (its name first, its control characters escaped), none the kernel's, so that the ULog's logged
// strings ("<source>: <text>") hold none that starts "kernel:"; the payload of the right size is routed as
// data, the one a byte too long is refused as a wrong size.
TEST_F(Hostile, ForgedKernelLinesAndUlogBytes_AllSignedByTheWorker_NoneAttributedToTheKernel) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "forge_log", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(2));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  EXPECT_EQ(o.front().value, 7) << "frames and lines the worker wrote";
  int forged = 0;
  for (const auto& [source, text] : log_lines_.lines) {
    if (text.find(escapes_mark) == std::string::npos) continue;
    ++forged;
    EXPECT_EQ(source, "worker") << text;
    for (const char ch : text) EXPECT_FALSE(static_cast<unsigned char>(ch) < 0x20 && ch != '\t') << text;
  }
  EXPECT_GE(forged, 5) << "the kernel did not log the worker's lines";
  for (const auto& line : log_.lines()) {
    EXPECT_TRUE(line.find(escapes_mark) == std::string::npos || line.rfind("[worker] ", 0) == 0) << line;
  }
  EXPECT_GE(k_->stats(id("worker")).wrong_size, 1U);
  EXPECT_EQ(k_->stats(id("worker")).bad_frames, k_->stats(id("worker")).wrong_size)
      << "a frame refused other than the publication of the wrong size";
  expect_nothing_escaped();
}

// Every field of the header broken, one datagram each: refused one by one, counted against the worker, the
// kernel reads on and the run goes on (the worker too: a bad frame is counted, not punished).
TEST_F(Hostile, BrokenFrames_EachRefusedAndCountedAgainstTheWorker_RunGoesOn) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "bad_frames", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(3));
  const auto o = outcomes();
  ASSERT_FALSE(o.empty()) << "no report from the worker";
  EXPECT_EQ(o.front().value, o.front().detail) << "frames the worker could not send";
  const kernel::ServiceStats w = k_->stats(id("worker"));
  EXPECT_GE(w.bad_frames, static_cast<std::uint64_t>(o.front().detail)) << "refused as bad frames";
  EXPECT_GE(w.denials, 1U) << "a publication on a slot it does not hold";
  EXPECT_GE(w.wrong_size, 1U) << "a publication of 3 bytes";
  EXPECT_EQ(k_->bad_frames_total(), w.bad_frames) << "counted against another service";
  EXPECT_EQ(k_->stats(id("driver")).bad_frames, 0U);
  EXPECT_GT(k_->stats(id("driver")).delivered, 0U);
  expect_nothing_escaped();
}

// A service that never reads its channel again (it sleeps in its MC tick): the kernel does not wait on it for
// ever nor queue for it without bound — it is killed as hung (counted against it), the rollback brings back its
// image, and the service that reads (the driver) loses nothing.
TEST_F(Hostile, StopsReadingItsChannel_KilledAsHung_TheOthersLoseNothing) {
  ASSERT_NO_FATAL_FAILURE(start({.name = "stop_reading", .at = "mc", .params = "", .limits = ""}));
  ASSERT_TRUE(step_until_rollbacks(3));
  const kernel::ServiceStats w = k_->stats(id("worker"));
  EXPECT_TRUE(w.hung || w.restores >= 1) << "never killed nor replaced";
  const kernel::ServiceStats d = k_->stats(id("driver"));
  EXPECT_EQ(d.lost, 0U) << "the driver's subscription overran";
  EXPECT_FALSE(d.hung);
  EXPECT_GT(d.delivered, 0U);
  EXPECT_FALSE(k_->stop_reason().has_value()) << k_->stop_detail();
  EXPECT_TRUE(victim_.alive());
}

}  // namespace
}  // namespace rejuv::testing
