// The Warden built alone (kernel_sim/kernel/src/warden.hpp): handed the graph, the options, the services and
// an epoll set (WardenParts), and peers that answer for the rest of the kernel (WardenPeers) from the test's
// own state, as Kernel::Impl answers from its owners. Shown by effect on real processes: the sweep kills a
// stray in a service's session (gone, killed by SIGKILL) and counts it, leaves what the kernel knows and what
// is in no service's session, waits for a copy on its way and sweeps it when due, kills a copy the kernel let
// go of unheard without counting it (as many as it let go of, no more); a violation is counted by kind,
// published, and rolls back at once in MC only; the output pipe's lines are logged under the service, a long
// one cut; the group's memory budget bounds each process where there is no cgroup. The seccomp notices are
// shown in a kernel run (tests/security).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "rejuv/sys/sanitizer.hpp"
#include "service_runtime.hpp"
#include "warden.hpp"

namespace rejuv::kernel {
namespace {

// The rest of the kernel as the Warden asks it, answered from what the test sets.
struct Peers final : WardenPeers {
  struct Event {
    ServiceId service;
    std::uint32_t detail;
    rejuv_msg_SecurityEventKind kind;
  };
  SrMode mode_now = SrMode::MC;
  bool sr = true;
  std::vector<std::string> lines;          // the kernel's log
  std::vector<std::string> service_lines;  // "<service>: <line>"
  std::vector<Event> events;
  std::vector<std::string> rollbacks;
  std::vector<image::Image> images;      // every image the kernel holds
  std::vector<pid_t> known;              // other children the kernel knows
  std::map<std::uint32_t, int> unheard;  // by ServiceId value
  std::vector<std::pair<pid_t, sys::ExitStatus>> killed;
  int settled = 0;

  [[nodiscard]] Nanos now() const override { return Nanos{0}; }
  [[nodiscard]] Nanos wall() const override {
    return std::chrono::duration_cast<Nanos>(std::chrono::steady_clock::now().time_since_epoch());
  }
  [[nodiscard]] SrMode mode() const override { return mode_now; }
  [[nodiscard]] bool rolls_back_on_violation() const override { return sr; }
  void log(const std::string& line) override { lines.push_back(line); }
  void service_log(ServiceRuntime& s, std::string_view line) override {
    service_lines.push_back(s.name + ": " + std::string(line));
  }
  void publish_security_event(ServiceId s, std::uint32_t detail, rejuv_msg_SecurityEventKind kind) override {
    events.push_back(Event{.service = s, .detail = detail, .kind = kind});
  }
  void request_rollback(std::string reason) override { rollbacks.push_back(std::move(reason)); }
  void for_each_image(const std::function<void(const image::Image&)>& f) const override {
    for (const image::Image& im : images) f(im);
  }
  [[nodiscard]] bool knows_child(pid_t pid) const override {
    for (const image::Image& im : images) {
      for (const sys::ChildProcess& c : im.copies) {
        if (c.pid() == pid) return true;
      }
    }
    return std::find(known.begin(), known.end(), pid) != known.end();
  }
  void settle_images() override { ++settled; }
  [[nodiscard]] bool checkpoint_running() const override { return false; }
  [[nodiscard]] bool owes_image(ServiceId /*s*/) const override { return false; }
  [[nodiscard]] bool take_unheard_copy(ServiceId s) override {
    int& n = unheard[s.value()];
    if (n == 0) return false;
    --n;
    return true;
  }
  void kill_and_reap_later(sys::ChildProcess p) override {
    const pid_t pid = p.pid();
    (void)p.signal(SIGKILL);
    auto status = p.wait();
    killed.emplace_back(pid, status ? *status : sys::ExitStatus{});
  }

  [[nodiscard]] bool said(const std::string& part) const {
    return std::any_of(lines.begin(), lines.end(),
                       [&](const std::string& l) { return l.find(part) != std::string::npos; });
  }
  [[nodiscard]] bool was_killed(pid_t pid) const {
    return std::any_of(killed.begin(), killed.end(), [&](const auto& k) {
      return k.first == pid && k.second.how == sys::ExitStatus::How::Signaled && k.second.value == SIGKILL;
    });
  }
};

// A Warden over `n` services named s0, s1 …, each with the launch graph's default spec.
struct Warded {
  explicit Warded(std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      proto::ServiceSpec* spec = graph.add_services();
      spec->set_name("s" + std::to_string(i));
    }
    services.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      services[i].id = ServiceId{static_cast<std::uint32_t>(i)};
      services[i].name = graph.services(static_cast<int>(i)).name();
      services[i].config.spec = &graph.services(static_cast<int>(i));
    }
  }
  proto::Launch graph;
  KernelOptions options;
  ClockMode clock = ClockMode::Lockstep;
  std::vector<ServiceRuntime> services;
  sys::Epoll epoll = std::move(*sys::Epoll::create());
  Peers peers;
  Warden warden{
      WardenParts{
          .graph = graph, .options = options, .clock_mode = clock, .services = services, .epoll = epoll},
      peers};
};

// A child of this process, alone in a session of its own until it is killed: to the kernel, a process of the
// service whose sessions list it.
struct SessionChild {
  SessionChild() {
    pid = ::fork();
    if (pid == 0) {
      (void)::setsid();
      for (;;) ::pause();
    }
    for (int i = 0; i < 2000 && ::getsid(pid) != pid; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  SessionChild(const SessionChild&) = delete;
  SessionChild& operator=(const SessionChild&) = delete;
  SessionChild(SessionChild&&) = delete;
  SessionChild& operator=(SessionChild&&) = delete;
  ~SessionChild() {
    if (alive()) {
      (void)::kill(pid, SIGKILL);
      (void)::waitpid(pid, nullptr, 0);
    }
  }
  // Still there and not a zombie (a zombie's /proc/PID/stat says Z).
  [[nodiscard]] bool alive() const {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string pid_field, comm, state;
    return static_cast<bool>(stat >> pid_field >> comm >> state) && state != "Z";
  }
  [[nodiscard]] bool gone() const { return !std::filesystem::exists("/proc/" + std::to_string(pid)); }
  pid_t pid = -1;
};

TEST(Warden, Sweep_KillsAndCountsAStrayInAServiceSession_LeavesWhatTheKernelKnowsAndOtherSessions) {
  Warded w(2);
  SessionChild stray, known, elsewhere;
  ASSERT_EQ(::getsid(stray.pid), stray.pid);
  w.services[1].sandbox.sessions = {known.pid, stray.pid};  // two incarnations' sessions of s1
  w.peers.known.push_back(known.pid);

  w.warden.sweep_strays("the test's sweep");

  EXPECT_TRUE(w.peers.was_killed(stray.pid));
  EXPECT_TRUE(stray.gone());
  EXPECT_TRUE(known.alive());
  EXPECT_TRUE(elsewhere.alive());
  EXPECT_EQ(w.services[1].stats.stray_processes, 1U);
  EXPECT_EQ(w.services[1].stats.sandbox_violations, 1U);
  EXPECT_EQ(w.services[0].stats.stray_processes, 0U);
  ASSERT_EQ(w.peers.events.size(), 1U);
  EXPECT_EQ(w.peers.events[0].service, ServiceId{1});
  EXPECT_EQ(w.peers.events[0].kind, rejuv_msg_SECURITY_STRAY_PROCESS);
  EXPECT_TRUE(w.peers.said("'s1' left a process behind: pid " + std::to_string(stray.pid) +
                           ", killed at the test's sweep (mode MC)"));
  ASSERT_EQ(w.peers.rollbacks.size(), 1U);  // in MC the attacker has the service: at once
  EXPECT_NE(w.peers.rollbacks[0].find("'s1'"), std::string::npos);
  EXPECT_GE(w.peers.settled, 1);  // the copies' answers read before anyone is judged
}

TEST(Warden, Sweep_WaitsWhileACopyOfTheServiceIsOnItsWay_SweepsItWhenDue_TheFinalSweepDoesNotWait) {
  Warded w(1);
  SessionChild stray;
  w.services[0].sandbox.sessions = {stray.pid};
  w.peers.images.emplace_back();
  w.peers.images.back().service = ServiceId{0};
  w.peers.images.back().spares_pending = 1;  // a spare asked for: its pid is not known yet

  w.warden.sweep_strays("a commit");
  EXPECT_TRUE(stray.alive()) << "a copy on its way may be this process: not judged yet";
  EXPECT_EQ(w.services[0].stats.stray_processes, 0U);

  w.peers.images.back().spares_pending = 0;  // its answer came
  w.warden.sweep_if_due();                   // the sweep asked for at the commit, not a second later
  EXPECT_TRUE(w.peers.was_killed(stray.pid));
  EXPECT_EQ(w.services[0].stats.stray_processes, 1U);
  EXPECT_TRUE(w.peers.said("killed at a commit"));

  SessionChild late;
  w.services[0].sandbox.sessions.push_back(late.pid);
  w.peers.images.back().spares_pending = 1;
  w.warden.sweep_strays("shutdown", /*final=*/true);
  EXPECT_TRUE(w.peers.was_killed(late.pid));
  EXPECT_EQ(w.services[0].stats.stray_processes, 2U);
}

TEST(Warden, Sweep_ACopyTheKernelLetGoOfUnheard_KilledNotCounted_NoMoreThanItLetGoOf) {
  Warded w(2);
  w.peers.mode_now = SrMode::SC;
  SessionChild a, b;
  w.services[0].sandbox.sessions = {a.pid, b.pid};
  w.peers.unheard[0] = 1;  // one spare of s0 asked for, its image let go of before it reported
  w.peers.unheard[1] = 5;  // s1's credit is not s0's

  w.warden.sweep_strays("the periodic sweep");

  EXPECT_TRUE(w.peers.was_killed(a.pid));
  EXPECT_TRUE(w.peers.was_killed(b.pid));
  EXPECT_EQ(w.services[0].stats.stray_processes, 1U) << "the second is a stray";
  EXPECT_EQ(w.peers.unheard[0], 0);
  EXPECT_EQ(w.peers.unheard[1], 5);
  const int lost =
      static_cast<int>(std::count_if(w.peers.lines.begin(), w.peers.lines.end(), [](const std::string& l) {
        return l.find("is a copy the kernel asked for and lost track of: killed, not counted") !=
               std::string::npos;
      }));
  EXPECT_EQ(lost, 1);
  EXPECT_TRUE(w.peers.rollbacks.empty()) << "in SC nothing rolls back";
}

TEST(Warden, Violation_CountedByKind_Published_RollsBackAtOnceInMCOnly) {
  Warded w(1);
  ServiceRuntime& s = w.services[0];
  w.peers.mode_now = SrMode::SC;
  w.warden.record_violation(s, Violation::ForbiddenCall, "ptrace");
  w.warden.record_violation(s, Violation::ForbiddenCall, "ptrace");
  EXPECT_EQ(s.stats.forbidden_calls, 2U);
  ASSERT_EQ(s.stats.calls_refused.size(), 1U);
  EXPECT_EQ(s.stats.calls_refused[0].first, "ptrace");
  EXPECT_EQ(s.stats.calls_refused[0].second, 2U);
  ASSERT_EQ(w.peers.events.size(), 2U);
  EXPECT_EQ(w.peers.events[0].kind, rejuv_msg_SECURITY_FORBIDDEN_CALL);
  EXPECT_EQ(w.peers.events[0].detail, static_cast<std::uint32_t>(sys::syscall_number("ptrace").value_or(0)));
  EXPECT_TRUE(w.peers.said("'s0' made a forbidden system call: ptrace (mode SC)"));
  EXPECT_TRUE(w.peers.rollbacks.empty());

  w.peers.mode_now = SrMode::MC;
  w.warden.record_violation(s, Violation::ImageLost, "its copies died");
  EXPECT_EQ(s.stats.images_lost, 1U);
  EXPECT_EQ(s.stats.sandbox_violations, 2U) << "a lost image may be a fault: not a violation of the service";
  EXPECT_EQ(w.peers.events.back().kind, rejuv_msg_SECURITY_IMAGE_LOST);
  ASSERT_EQ(w.peers.rollbacks.size(), 1U);

  w.peers.sr = false;  // without SR (or at shutdown) nothing rolls back
  w.warden.record_violation(s, Violation::OutOfMemory, "1 process(es)");
  EXPECT_EQ(s.stats.out_of_memory, 1U);
  EXPECT_EQ(w.peers.events.back().kind, rejuv_msg_SECURITY_OUT_OF_MEMORY);
  EXPECT_EQ(w.peers.rollbacks.size(), 1U);
}

TEST(Warden, Output_LinesLoggedUnderTheService_ALongLineCut_TheLastPartialOneAtTheEnd_ThePipeClosed) {
  Warded w(1);
  ServiceRuntime& s = w.services[0];
  int fds[2] = {-1, -1};
  ASSERT_EQ(::pipe2(fds, O_NONBLOCK | O_CLOEXEC), 0);
  ASSERT_TRUE(w.warden.replace_output(s, sys::UniqueFd(fds[0])).has_value());
  const std::string text = "hello\nworld\n" + std::string(1500, 'x') + "tail";
  ASSERT_EQ(::write(fds[1], text.data(), text.size()), static_cast<ssize_t>(text.size()));

  w.warden.on_service_output(s);
  ASSERT_EQ(w.peers.service_lines.size(), 3U);
  EXPECT_EQ(w.peers.service_lines[0], "s0: hello");
  EXPECT_EQ(w.peers.service_lines[1], "s0: world");
  EXPECT_EQ(w.peers.service_lines[2], "s0: " + std::string(1024, 'x'));
  EXPECT_TRUE(s.sandbox.output.valid());

  ::close(fds[1]);  // every writer gone: the rest is a line, the pipe is closed
  w.warden.on_service_output(s);
  ASSERT_EQ(w.peers.service_lines.size(), 4U);
  EXPECT_EQ(w.peers.service_lines[3], "s0: " + std::string(476, 'x') + "tail");
  EXPECT_EQ(s.stats.output_lines, 4U);
  EXPECT_FALSE(s.sandbox.output.valid());
}

TEST(Warden, Limits_WithoutACgroup_TheGroupsMemoryBudgetBoundsEachProcess) {
  Warded w(2);
  w.graph.mutable_services(0)->mutable_limits()->set_max_group_memory_mb(64);
  w.graph.mutable_services(0)->mutable_limits()->set_max_memory_mb(0);
  w.graph.mutable_services(1)->mutable_limits()->set_max_group_memory_mb(64);
  w.graph.mutable_services(1)->mutable_limits()->set_max_memory_mb(32);
  ASSERT_FALSE(w.services[0].sandbox.cgroup.bounds_memory());
  const sys::ResourceLimits l0 = w.warden.limits_for(w.services[0]);
  const sys::ResourceLimits l1 = w.warden.limits_for(w.services[1]);
#if defined(REJUV_TSAN)
  GTEST_SKIP() << "no address-space limit in a TSan build";
#else
  EXPECT_EQ(l0.address_space, (std::uint64_t{64} << 20U) + sys::kSanitizerAddressSpace);
  EXPECT_EQ(l1.address_space, (std::uint64_t{32} << 20U) + sys::kSanitizerAddressSpace);
#endif
  EXPECT_EQ(l0.open_files, launch::sandbox_limits(w.graph, w.graph.services(0)).max_open_files);
}

}  // namespace
}  // namespace rejuv::kernel
