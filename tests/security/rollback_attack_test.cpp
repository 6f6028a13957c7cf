// The attacks on rollback itself (idl/launch.proto AttackKind 18…27 and 32; services/attacks
// rollback_attacks.cpp; docs/sandbox.md "Threats to rollback"), each carried out by a compromised ext_link in
// every MC window of the square (launch/quad_square_paper.launch.pbtxt, with its worst-case control attack), flown
// through the real kernel, the real flight services and the plant — in REAL TIME and in LOCKSTEP. Lockstep
// stops the world while the kernel cleans up; a vehicle does not, so both are flown.
//
// Each is judged by its effect: the vehicle stayed in the safety set (max V < 1); every rollback restored a
// checkpoint (no cold restart, no image lost); the kernel — this process — is alive (a SIGKILL to it would
// end the test); the attack was counted by kind where it is a violation (the fcntl refused by name, the
// strays counted, the live incarnation's OOM kill counted) and not counted where it is none (raise() from a thread); no restored incarnation of
// ext_link ever had O_ASYNC on its channel or log fds; no forged kernel line or escape reached the log; the
// pagemap shows no frame numbers; after the run no process of ext_link's session is left and the kernel has
// no child. The default (root) run is one test per kind and clock; SigioKernelWithoutRoot runs the kernel as
// an unprivileged user, where SIGIO with SIGKILL killed it. No timing is asserted.
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "graph_fixture.hpp"
#include "mission_support.hpp"
#include "rejuv/attacks/plan.hpp"
#include "rejuv/launch/launch.hpp"
#include "run_recorder.hpp"
#include "run_summary.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using attacks::AttackKind;
using kernel::Kernel;
using kernel::StopReason;

// Kernel time flown: the alignment, the take-off and about three SR cycles (T_est 3 s + T_MC 0.3 s).
constexpr std::chrono::seconds kFlight{14};
constexpr int kAsyncFlag = 020000;  // O_ASYNC (FASYNC) in /proc/<pid>/fdinfo "flags:" (octal)

using mission::missing_executable;
using mission::read_text;
using mission::RunLog;
using mission::session_members;
using mission::SessionGuard;

// quad_square_paper with ext_link compromised by `kind` (every MC window) next to the worst-case control attack,
// flown in `clock`. Empty when the graph no longer reads as expected (the caller fails).
// hold_mib > 0: the attack's magnitude, and a start past the flight's end (OOM_IMAGES: a service that only
// holds that much memory from boot).
std::string attacked_square(AttackKind kind, bool realtime, std::uint32_t hold_mib = 0) {
  std::string t = read_text(fs::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt");
  const std::string control_attack = "attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }";
  const std::size_t at = t.find(control_attack);
  const std::size_t clock = t.find("clock: LOCKSTEP");
  if (at == std::string::npos || clock == std::string::npos) return {};
  t.insert(at + control_attack.size(),
           "\n  attacks { kind: " + std::string(attacks::to_string(kind)) + " service: \"ext_link\"" +
               (hold_mib > 0 ? " magnitude: " + std::to_string(hold_mib) + " start_s: 100000" : std::string()) +
               " }");
  if (realtime) t.replace(clock, std::string_view("clock: LOCKSTEP").size(), "clock: REALTIME");
  // A shorter alignment than the mission's 20 s (the estimate converges in less; real time pays it in full).
  const std::size_t align = t.find("alignment_s: 20");
  if (align == std::string::npos) return {};
  t.replace(align, std::string_view("alignment_s: 20").size(), "alignment_s: 8");
  return t;
}

// The "flags:" of /proc/<pid>/fdinfo/<fd> (octal), or nullopt when unreadable (the process is gone).
std::optional<int> fd_flags(pid_t pid, int fd) {
  std::istringstream in(read_text("/proc/" + std::to_string(pid) + "/fdinfo/" + std::to_string(fd)));
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("flags:", 0) == 0) return static_cast<int>(std::strtol(line.c_str() + 6, nullptr, 8));
  }
  return std::nullopt;
}

// The scheduling policy of `pid` (/proc/<pid>/stat field 41: 0 SCHED_OTHER, 1 SCHED_FIFO), or nullopt.
std::optional<int> policy_of(pid_t pid) {
  const auto policy = mission::proc_stat(pid).number(41);
  if (!policy) return std::nullopt;
  return static_cast<int>(*policy);
}

// The CPUs `pid` may run on (/proc/<pid>/status Cpus_allowed_list, e.g. "1" or "0-1"), or "" when unreadable.
std::string cpus_of(pid_t pid) {
  std::istringstream in(read_text("/proc/" + std::to_string(pid) + "/status"));
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Cpus_allowed_list:", 0) == 0) {
      const std::size_t v = line.find_first_not_of(" \t", sizeof("Cpus_allowed_list:") - 1);
      return v == std::string::npos ? std::string() : line.substr(v);
    }
  }
  return {};
}

// The CPU the real-time flights pin lqr_control to (launch `cpu`): the machine's last.
unsigned pinned_cpu() { return static_cast<unsigned>(std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN)) - 1); }

// Watches ext_link through the run: its session, and the flags of each live incarnation's fds 1–3 (about
// every 100 ms of kernel time). Beside `rejuv run`'s recorder, in an ObserverFanout.
class Watch final : public kernel::Observer {
 public:
  explicit Watch(SessionGuard& guard) : guard_(guard) {}
  void attach(Kernel* k) { kernel_ = k; }

  void on_step(std::uint64_t /*step*/, Nanos t, SrMode /*mode*/) override {
    if (kernel_ == nullptr || t - last_look_ < std::chrono::milliseconds{100}) return;
    last_look_ = t;
    const auto id = kernel_->find_service("ext_link");
    if (!id) return;
    const int pid = kernel_->stats(*id).pid;
    if (pid <= 0) return;
    if (!sid) {
      if (const pid_t s = ::getsid(pid); s > 0) {
        sid = s;
        guard_.watch(s);
      }
    }
    if (std::find(incarnations.begin(), incarnations.end(), pid) == incarnations.end()) incarnations.push_back(pid);
    // The real-time plan (docs/realtime.md): the live controller at SCHED_FIFO, its images never above it.
    if (const auto lqr = kernel_->find_service("lqr_control")) {
      const pid_t live = kernel_->stats(*lqr).pid;
      if (policy_of(live) == 1) ++chain_fifo;
      if (const std::string cpus = cpus_of(live); !cpus.empty()) {
        if (cpus == std::to_string(pinned_cpu())) {
          ++chain_pinned;
        } else {
          unpinned.push_back("pid " + std::to_string(live) + " on " + cpus);
        }
      }
      for (const pid_t image : kernel_->image_pids(*lqr)) image_fifo += policy_of(image) == 1 ? 1 : 0;
    }
    for (const int fd : {1, 2, 3}) {
      const auto flags = fd_flags(pid, fd);
      if (flags && (*flags & kAsyncFlag) != 0) async_fds.push_back("pid " + std::to_string(pid) + " fd " + std::to_string(fd));
    }
  }

  std::optional<pid_t> sid{};
  std::vector<pid_t> incarnations{};     // ext_link's live pids seen
  std::vector<std::string> async_fds{};  // fds seen with O_ASYNC
  int chain_fifo = 0;                    // looks that found the live lqr_control at SCHED_FIFO
  int image_fifo = 0;                    // images of lqr_control found at SCHED_FIFO
  int chain_pinned = 0;                  // looks that found the live lqr_control on its launch `cpu` alone
  std::vector<std::string> unpinned{};   // looks that found it allowed elsewhere

 private:
  SessionGuard& guard_;
  Kernel* kernel_ = nullptr;
  Nanos last_look_{0};
};

std::uint64_t refused(const kernel::ServiceStats& s, std::string_view call) {
  for (const auto& [name, n] : s.calls_refused) {
    if (name == call) return n;
  }
  return 0;
}

struct Flight {
  proto::RunSummary summary;
  kernel::RunOutcome outcome;
  kernel::ServiceStats ext_link;
  kernel::SrStats sr;
  std::string log;
  std::vector<std::string> forged_lines;   // lines that begin as the forged kernel line
  std::vector<std::string> async_fds;
  std::size_t incarnations = 0;
  int chain_fifo = 0;
  int image_fifo = 0;
  int chain_pinned = 0;
  std::vector<std::string> unpinned;
  bool realtime = false;
  bool plan_applied = false;  // the kernel logged its real-time plan as applied (not refused by the machine)
  std::vector<pid_t> left_in_session;
  int children_left = 0;
};

// The lines of the log that contain `needle`.
std::vector<std::string> lines_with(const std::string& log, std::string_view needle) {
  std::vector<std::string> out;
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);) {
    if (line.find(needle) != std::string::npos) out.push_back(line);
  }
  return out;
}

// Flies the attacked square for kFlight and gathers what the assertions need. Fatal failures are reported
// through gtest (the caller checks HasFatalFailure).
void fly(AttackKind kind, bool realtime, Flight& f, std::uint32_t hold_mib = 0) {
  const std::string text = attacked_square(kind, realtime, hold_mib);
  ASSERT_FALSE(text.empty()) << "launch/quad_square_paper.launch.pbtxt no longer has the control attack, clock or alignment";
  auto graph = launch::parse_launch(text, fs::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt");
  ASSERT_TRUE(graph.has_value()) << graph.error().to_string();
  if (const auto missing = missing_executable(*graph)) FAIL() << "not built: " << missing->string();
  if (realtime) {  // the plan's CPU pinning (launch `cpu`), checked by effect in every look (Watch)
    for (proto::ServiceSpec& s : *graph->graph.mutable_services()) {
      if (s.name() == "lqr_control") s.set_cpu(pinned_cpu());
    }
  }
  auto reference = cli::run_reference(*graph, std::nullopt);
  ASSERT_TRUE(reference.has_value()) << reference.error();

  RunLog log;
  ASSERT_NE(log.get(), nullptr);
  kernel::KernelOptions options = mission::mission_options(log.get());
  options.duration = reference->alignment + Nanos{kFlight};  // counted from the end of the alignment, as `rejuv run`
  const int children_before = Resources::now().children;

  SessionGuard guard;  // declared before the kernel: runs after its destructor
  cli::RunRecorder recorder(std::move(*reference), nullptr, cli::RunRecorder::Progress::Off);
  Watch watch(guard);
  kernel::ObserverFanout both({&recorder, &watch});
  auto k = Kernel::create(std::move(*graph), options, &both);
  ASSERT_TRUE(k.has_value()) << k.error().to_string();
  watch.attach(k->get());
  recorder.on_vehicle_lost([kernel = k->get()] { (*kernel).request_stop(); });

  auto outcome = (*k)->run();
  ASSERT_TRUE(outcome.has_value()) << outcome.error().to_string() << "\n" << log.text();
  f.outcome = *outcome;
  cli::fill_summary(f.summary, **k, recorder, *outcome, cli::facts_of(**k, options));
  const auto id = (*k)->find_service("ext_link");
  ASSERT_TRUE(id.has_value());
  f.ext_link = (*k)->stats(*id);
  f.sr = (*k)->sr_stats();
  k->reset();
  f.log = log.text();
  f.forged_lines = log.lines_starting("[kernel 99.999]");
  f.async_fds = watch.async_fds;
  f.incarnations = watch.incarnations.size();
  f.chain_fifo = watch.chain_fifo;
  f.image_fifo = watch.image_fifo;
  f.chain_pinned = watch.chain_pinned;
  f.unpinned = watch.unpinned;
  f.realtime = realtime;
  // Applied to lqr_control: another kernel on the machine may hold the real-time budget (cgroup v1
  // cpu.rt_runtime_us is shared), and then the kernel says which services it refused.
  f.plan_applied = f.log.find("real-time plan: kernel SCHED_FIFO") != std::string::npos &&
                   f.log.find("'lqr_control' refused SCHED_FIFO") == std::string::npos;
  if (watch.sid) f.left_in_session = session_members(*watch.sid);
  f.children_left = Resources::now().children - children_before;
  ::testing::Test::RecordProperty("max_V", std::to_string(f.summary.max_v()));
  ::testing::Test::RecordProperty("max_control_gap_ms", std::to_string(f.summary.max_control_gap_ms()));
  ::testing::Test::RecordProperty("rollbacks", std::to_string(f.sr.rollbacks));
  ::testing::Test::RecordProperty("sandbox_violations", std::to_string(f.ext_link.sandbox_violations));
  std::printf(
      "[ %s %s ] max V %.3f, max control gap %.1f ms, %llu rollbacks, %llu cold restarts, ext_link: "
      "%llu violations (%llu calls, %llu strays, %llu out of memory, %llu images lost), %zu incarnations "
      "seen; lqr_control at SCHED_FIFO in %d looks, on its launch cpu in %d; %zu copies the kernel lost "
      "track "
      "of killed\n",
      std::string(attacks::to_string(kind)).c_str(), realtime ? "real time" : "lockstep", f.summary.max_v(),
      f.summary.max_control_gap_ms(), static_cast<unsigned long long>(f.sr.rollbacks),
      static_cast<unsigned long long>(f.sr.cold_restarts),
      static_cast<unsigned long long>(f.ext_link.sandbox_violations),
      static_cast<unsigned long long>(f.ext_link.forbidden_calls),
      static_cast<unsigned long long>(f.ext_link.stray_processes),
      static_cast<unsigned long long>(f.ext_link.out_of_memory),
      static_cast<unsigned long long>(f.ext_link.images_lost), f.incarnations, f.chain_fifo, f.chain_pinned,
      lines_with(f.log, "a copy the kernel asked for and lost track of").size());
}

// What no attack on rollback may do, whatever it was.
void expect_rollback_held(const Flight& f) {
  EXPECT_EQ(f.outcome.reason, StopReason::Duration) << f.outcome.detail;
  EXPECT_LT(f.summary.max_v(), 1.0) << "the vehicle left the safety set";
  EXPECT_FALSE(f.summary.left_safety_set());
  EXPECT_GE(f.sr.rollbacks, 2U) << "too few rollbacks for the attack to matter";
  EXPECT_EQ(f.sr.cold_restarts, 0U) << "a rollback found no usable image";
  EXPECT_EQ(f.ext_link.images_lost, 0U) << "an image of ext_link died or stopped in the store";
  EXPECT_TRUE(f.async_fds.empty()) << "O_ASYNC on " << ::testing::PrintToString(f.async_fds);
  EXPECT_TRUE(f.forged_lines.empty()) << "a forged kernel line reached the log: " << f.forged_lines.front();
  EXPECT_EQ(f.log.find('\x1b'), std::string::npos) << "an escape reached the log";
  EXPECT_EQ(f.log.find('\r'), std::string::npos) << "a carriage return reached the log";
  EXPECT_EQ(f.left_in_session, std::vector<pid_t>{}) << "left in ext_link's session after the run";
  EXPECT_EQ(f.children_left, 0) << "the kernel has children left";
  // The square's real-time plan where the machine granted it: the chain at SCHED_FIFO, never an image (reset
  // on fork). Where it was refused (no CAP_SYS_NICE, a container), nothing at all may be SCHED_FIFO.
  if (f.realtime && f.plan_applied) {
    EXPECT_GT(f.chain_fifo, 0) << "lqr_control was never seen at SCHED_FIFO";
    // Pinned (launch `cpu`) in every incarnation the rollbacks made live, not only the first.
    EXPECT_GT(f.chain_pinned, 0) << "lqr_control was never seen on CPU " << pinned_cpu() << " alone";
    EXPECT_EQ(f.unpinned, std::vector<std::string>{}) << "the live lqr_control off its launch cpu";
  }
  EXPECT_EQ(f.image_fifo, 0) << "an image of lqr_control ran at SCHED_FIFO";
}

// A binary hostile from its first instruction (AttackKind 29…31, services/attacks/src/boot_attacks.cpp): what
// it tried at boot was refused by the kernel (EPERM), counted against ext_link by call, and achieved nothing.
void expect_boot_attack_refused(AttackKind kind, const Flight& f) {
  const auto& s = f.ext_link;
  const std::string calls = ::testing::PrintToString(s.calls_refused);
  if (kind == AttackKind::BootTimePage) {
    // The magic link's O_RDWR reopen refused by its flags; a writable mapping of the read-only fd refused by
    // the kernel; in every MC window nothing written (the page sealed, the fd read-only) — the page stayed
    // the kernel's, which the flight shows: every service read its clock and the vehicle flew.
    EXPECT_GE(refused(s, "openat"), 1U) << calls;
    const auto boot = lines_with(f.log, "attack BOOT_TIME_PAGE: at boot");
    ASSERT_EQ(boot.size(), 1U) << "ext_link's boot step not logged once";
    EXPECT_NE(boot[0].find("writable fd refused"), std::string::npos) << boot[0];
    EXPECT_NE(boot[0].find("writable mapping refused"), std::string::npos) << boot[0];
    const auto windows = lines_with(f.log, "attack BOOT_TIME_PAGE: odd sequence");
    EXPECT_GE(windows.size(), 2U) << "too few attacked windows for the attack to matter";
    for (const std::string& w : windows) {
      EXPECT_NE(w.find("odd sequence refused"), std::string::npos) << w;
      EXPECT_NE(w.find("not stored by the mapping"), std::string::npos) << w;
    }
    EXPECT_TRUE(lines_with(f.log, "time page: ").empty()) << "a reader of the time page gave up";
  } else if (kind == AttackKind::BootPrlimitKernel) {
    // The kernel is this process: alive, or the test would not be here. Refused by the kernel, not run.
    EXPECT_GE(refused(s, "prlimit64"), 1U) << calls;
    const auto tried = lines_with(f.log, "attack BOOT_PRLIMIT_KERNEL: prlimit64(");
    ASSERT_EQ(tried.size(), 1U);
    EXPECT_NE(tried[0].find("errno 1"), std::string::npos) << tried[0];  // EPERM
    rlimit cpu{};
    ASSERT_EQ(::getrlimit(RLIMIT_CPU, &cpu), 0);
    EXPECT_EQ(cpu.rlim_cur, RLIM_INFINITY) << "the kernel's CPU limit was changed";
  } else if (kind == AttackKind::BootReadSecrets) {
    // The kernel's command line (here the test's; `rejuv run` names the launch file there: boot_secret_test.cpp)
    // is another process's /proc: refused at boot and counted.
    EXPECT_GE(refused(s, "openat"), 1U) << calls;
    const auto tried = lines_with(f.log, "attack BOOT_READ_SECRETS: ");
    ASSERT_EQ(tried.size(), 1U);
    EXPECT_NE(tried[0].find("kernel cmdline unread"), std::string::npos) << tried[0];
    EXPECT_FALSE(lines_with(f.log, "outside what a start-up reads").empty()) << "the refused open was not named";
  }
}

// What each kind must leave in the counters (the kernel saw it, by kind; or saw nothing where nothing was wrong).
void expect_counted(AttackKind kind, const Flight& f) {
  const auto& s = f.ext_link;
  if (std::ranges::find(attacks::kBootAttackKinds, kind) != attacks::kBootAttackKinds.end()) {
    expect_boot_attack_refused(kind, f);
  } else if (kind == AttackKind::SigioImages || kind == AttackKind::SigioKernel || kind == AttackKind::SigioLogTrap) {
    EXPECT_GE(refused(s, "fcntl"), 1U) << "calls refused: " << ::testing::PrintToString(s.calls_refused);
  } else if (kind == AttackKind::StraySpinners || kind == AttackKind::StrayMemory) {
    EXPECT_GE(s.stray_processes, 1U);
    // Blamed on the service that made them, never on another.
    for (const auto& [name, count] : f.summary.sandbox_violations().by_service()) {
      EXPECT_EQ(name, "ext_link") << "a stray of ext_link's blamed on '" << name
                                  << "': " << ::testing::PrintToString(lines_with(f.log, "'" + name + "'"));
    }
  } else if (kind == AttackKind::OomImages) {
    // The live incarnation that ran its memory out is the one the OOM killer took (its images are in a leaf
    // of their own: expect_rollback_held checks that none was lost), counted against ext_link by kind.
    EXPECT_FALSE(lines_with(f.log, "attack OOM_IMAGES: its copy unmapped").empty()) << "never attacked in MC";
    if (s.cgroup.find("memory") == std::string::npos) {
      std::printf("no memory cgroup here (%s): no OOM to count\n", s.cgroup.c_str());
    } else if (f.realtime && s.out_of_memory == 0) {
      // In real time the window's rollback may come before the touch reaches the limit (a loaded machine
      // touches slower than T_MC): then nothing ran out, and what must hold is expect_rollback_held's (no image
      // lost, no cold restart). Lockstep waits for the touch, so there the OOM always happens and is counted.
      std::printf("OOM_IMAGES real time: every window's rollback came before its touch reached the limit\n");
      EXPECT_EQ(s.sandbox_violations, 0U);
    } else {
      EXPECT_GE(s.out_of_memory, 1U) << "the OOM kill was not counted";
      EXPECT_GE(s.sandbox_violations, s.out_of_memory);
      EXPECT_EQ(f.summary.sandbox_violations().by_service().count("ext_link"), 1U);
      EXPECT_FALSE(lines_with(f.log, "sandbox violation: 'ext_link' ran its live cgroup out of memory").empty());
    }
  } else {
    // Not violations (threads, a signal to itself, a log line, a read of what it was handed): nothing may be
    // counted, nothing killed.
    EXPECT_EQ(s.sandbox_violations, 0U) << "calls refused: " << ::testing::PrintToString(s.calls_refused);
  }
  if (kind == AttackKind::RetiredWorker) {
    EXPECT_EQ(f.log.find("RETIRED-WORKER"), std::string::npos) << "a retired incarnation ran after the rollback";
    EXPECT_EQ(s.bad_frames, 0U) << "garbage frames reached the kernel";
  }
  if (kind == AttackKind::ForgedLog) {
    // Logged, under its name, on one line.
    bool signed_line = false;
    std::istringstream in(f.log);
    for (std::string line; std::getline(in, line);) {
      if (line.find("FORGED-BY-SERVICE") != std::string::npos) signed_line = line.starts_with("[ext_link] ");
    }
    EXPECT_TRUE(signed_line) << "the forged line was not logged under ext_link's name";
  }
  if (kind == AttackKind::PagemapFrames) {
    std::istringstream in(f.log);
    int looked = 0;
    for (std::string line; std::getline(in, line);) {
      if (line.find("attack PAGEMAP_FRAMES: pagemap fd ") == std::string::npos) continue;
      if (line.find("pagemap fd -1") != std::string::npos) continue;  // not handed yet (no checkpoint since)
      ++looked;
      EXPECT_NE(line.find(", 0 frame numbers seen"), std::string::npos) << line;
    }
    EXPECT_GE(looked, 1) << "ext_link never found its pagemap";
  }
}

// OOM_IMAGES held from boot and never touched again, without root (no memory cgroup): below the group's
// budget (1 GiB) it is bounded in cost — every image after the alignment's is by written pages, none by a
// fork whose cost grows with the memory; above it the memory is refused (RLIMIT_AS is the group's budget).
void expect_idle_memory_bounded(std::uint32_t hold_mib, const Flight& f) {
  const std::string held = "attack OOM_IMAGES: " + std::to_string(hold_mib) + " MiB touched and kept";
  // Room below the group's budget for what the service maps besides the held memory.
  if (hold_mib <= launch::defaults::kSandboxGroupMemoryMb - 64) {
    EXPECT_EQ(lines_with(f.log, held).size(), 1U) << "the memory was not held";
    EXPECT_GT(f.sr.images_by_pages, 0U) << "no image by written pages without root";
    // The alignment's images are by fork (one per rejuvenated service): nothing after them.
    const auto rejuvenated = static_cast<std::uint64_t>(std::ranges::count_if(
        f.summary.services(), [](const proto::ServiceSummary& s) { return s.rejuvenated(); }));
    EXPECT_GT(rejuvenated, 0U);
    EXPECT_LE(f.sr.images_by_fork, rejuvenated)
        << "images by fork after the alignment: their cost grows with the memory";
  } else {
    EXPECT_TRUE(lines_with(f.log, held).empty()) << "more than the group's budget was held without a cgroup";
    EXPECT_EQ(lines_with(f.log, "attack OOM_IMAGES (epoch 0, SC): 1 attempts, 0 accepted").size(), 1U)
        << "the boot touch was not tried, or not refused";
  }
  EXPECT_EQ(f.ext_link.sandbox_violations, 0U);
  EXPECT_EQ(f.summary.sandbox_violations().by_service().size(), 0U) << "a violation blamed on a service";
}

struct Case {
  AttackKind kind;
  bool realtime;
};

class RollbackAttack : public ::testing::TestWithParam<Case> {};

TEST_P(RollbackAttack, VehicleSafe_CheckpointRestored_CountedByKind_NothingLeft) {
  Flight f;
  fly(GetParam().kind, GetParam().realtime, f);
  if (HasFatalFailure() || IsSkipped()) return;
  expect_rollback_held(f);
  expect_counted(GetParam().kind, f);
}

std::vector<Case> all_cases() {
  std::vector<Case> out;
  for (const bool realtime : {true, false}) {
    for (const AttackKind k : attacks::kRollbackAttackKinds) out.push_back(Case{k, realtime});
    for (const AttackKind k : attacks::kBootAttackKinds) out.push_back(Case{k, realtime});
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Containment, RollbackAttack, ::testing::ValuesIn(all_cases()),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           std::string name(attacks::to_string(i.param.kind));
                           std::erase(name, '_');
                           return name + (i.param.realtime ? "_RealTime" : "_Lockstep");
                         });

// ---- without root: the kernel runs as an unprivileged user (each service in a user namespace of its own,
// with the kernel's real uid), where SIGIO with SIGKILL aimed at the kernel's pid killed the whole runtime ----

constexpr const char* kInnerEnv = "REJUV_TEST_UNPRIVILEGED_KERNEL";

// The inner run (this binary re-executed as the unprivileged user): the flight and its assertions. The
// variable says "<realtime|lockstep>:<ATTACK_KIND>".
TEST(RollbackAttackWithoutRoot, Inner) {
  const char* inner = std::getenv(kInnerEnv);
  if (inner == nullptr) GTEST_SKIP() << "run by RollbackAttackWithoutRoot.* (re-executed without root)";
  ASSERT_NE(::geteuid(), 0U);
  const std::string_view spec(inner);
  const std::size_t colon = spec.find(':');
  ASSERT_NE(colon, std::string_view::npos) << spec;
  const std::string_view rest = spec.substr(colon + 1);
  const std::size_t second = rest.find(':');
  const auto kind = attacks::attack_kind_from_name(rest.substr(0, second));
  ASSERT_TRUE(kind.has_value()) << spec;
  std::uint32_t hold_mib = 0;
  if (second != std::string_view::npos) {
    const std::string_view n = rest.substr(second + 1);
    ASSERT_EQ(std::from_chars(n.data(), n.data() + n.size(), hold_mib).ec, std::errc{}) << spec;
  }
  Flight f;
  fly(*kind, spec.substr(0, colon) == "realtime", f, hold_mib);
  if (HasFatalFailure() || IsSkipped()) return;
  expect_rollback_held(f);
  if (hold_mib > 0) {
    expect_idle_memory_bounded(hold_mib, f);
  } else {
    expect_counted(*kind, f);
  }
}

struct UnprivilegedCase {
  AttackKind kind;
  bool realtime;
  std::uint32_t hold_mib = 0;  // OOM_IMAGES: MiB held from boot, never touched again
};

class RollbackAttackWithoutRoot : public ::testing::TestWithParam<UnprivilegedCase> {};

TEST_P(RollbackAttackWithoutRoot, KernelAlive_AttackRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to become the unprivileged user";
  const passwd* nobody = ::getpwnam("nobody");
  ASSERT_NE(nobody, nullptr);
  // The user must reach the build: every directory on the way to it searchable by others.
  for (fs::path p = fs::path(REJUV_BINARY_DIR); !p.empty() && p != p.root_path(); p = p.parent_path()) {
    if ((fs::status(p).permissions() & fs::perms::others_exec) == fs::perms::none) {
      GTEST_SKIP() << p << " is not searchable by other users";
    }
  }
  // Everything the child needs is made before the fork (this process has threads: the child only calls
  // async-signal-safe functions, then execs).
  const std::string self = fs::read_symlink("/proc/self/exe");
  const std::string filter = "--gtest_filter=RollbackAttackWithoutRoot.Inner";
  std::vector<std::string> env_text;
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::string_view(*e).starts_with("HOME=")) continue;
    env_text.emplace_back(*e);
  }
  env_text.push_back(std::string(kInnerEnv) + "=" + (GetParam().realtime ? "realtime" : "lockstep") + ":" +
                     std::string(attacks::to_string(GetParam().kind)) +
                     (GetParam().hold_mib > 0 ? ":" + std::to_string(GetParam().hold_mib) : std::string()));
  env_text.emplace_back("HOME=/tmp");
  std::vector<char*> env;
  for (std::string& e : env_text) env.push_back(e.data());
  env.push_back(nullptr);
  std::array<char*, 3> argv{const_cast<char*>(self.c_str()), const_cast<char*>(filter.c_str()), nullptr};  // NOLINT
  const gid_t gid = nobody->pw_gid;
  const uid_t uid = nobody->pw_uid;
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (::setgroups(0, nullptr) != 0 || ::setresgid(gid, gid, gid) != 0 || ::setresuid(uid, uid, uid) != 0) {
      ::_exit(90);
    }
    ::execve(self.c_str(), argv.data(), env.data());
    ::_exit(91);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_FALSE(WIFSIGNALED(status)) << "the unprivileged kernel was killed by signal " << WTERMSIG(status);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 90) << "could not become the unprivileged user";
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the flight without root failed (its output is above)";
}

// SIGIO with SIGKILL at the kernel (it shares no uid with a service: no signal reaches it), 40 spinning strays
// per window (no cgroup without root), and each attack of a binary hostile from boot, where the services once
// had the kernel's uid (prlimit64 on it, its /proc).
std::vector<UnprivilegedCase> unprivileged_cases() {
  std::vector<UnprivilegedCase> out;
  for (const bool realtime : {true, false}) {
    out.push_back(UnprivilegedCase{AttackKind::SigioKernel, realtime});
    // 40 spinning strays per window where no cgroup can be made: swept one by one (warden.cpp), their cost
    // bounded by the pids rlimit of the service's own subordinate uid.
    out.push_back(UnprivilegedCase{AttackKind::StraySpinners, realtime});
    for (const AttackKind k : attacks::kBootAttackKinds) out.push_back(UnprivilegedCase{k, realtime});
    // A service holding memory it never touches again: 900 MiB bounded in cost (images by written pages),
    // 3 GiB refused (no memory cgroup: RLIMIT_AS is the group's budget).
    out.push_back(UnprivilegedCase{AttackKind::OomImages, realtime, 900});
    out.push_back(UnprivilegedCase{AttackKind::OomImages, realtime, 3072});
    // The pagemap handed over by the agent in the service's namespace (rejuv/sys/pagemap_agent.hpp): no
    // physical frame numbers either.
    out.push_back(UnprivilegedCase{AttackKind::PagemapFrames, realtime});
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Containment, RollbackAttackWithoutRoot, ::testing::ValuesIn(unprivileged_cases()),
                         [](const ::testing::TestParamInfo<UnprivilegedCase>& i) {
                           std::string name(attacks::to_string(i.param.kind));
                           std::erase(name, '_');
                           if (i.param.hold_mib > 0) name = "HOLD" + std::to_string(i.param.hold_mib) + "MIB";
                           return name + (i.param.realtime ? "_RealTime" : "_Lockstep");
                         });

}  // namespace
}  // namespace rejuv::testing
