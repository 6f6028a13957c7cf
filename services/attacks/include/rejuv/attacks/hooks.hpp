// The runtime attack hooks (docs/design.md §9, §11; idl/launch.proto AttackKind 2…12): a compromised service
// carrying out the launch plan's attacks against the runtime, through its real channel and real system
// calls — nothing is simulated, the kernel and the sandbox decide. Test builds only (REJUV_ATTACK_HOOKS).
//
//   #if defined(REJUV_ATTACK_HOOKS)
//     auto hooks = rejuv::attacks::install(svc);                // before svc.run()
//     if (!svc.require(hooks, "bad attack params")) return 1;
//   #endif
//
// install() reads the plan from the boot params (plan.hpp) and, if a runtime attack names this service,
// carries out the boot-time attacks at once and, if a windowed one is left, arms one kernel timer; at the
// first tick of every attacked window (WindowClock) it carries out each windowed attack of the plan once:
//   INVOKE_CHECKPOINT  CheckpointCreate and CheckpointRollback on its Checkpoint caps, other caps and never-held slots
//   ARM_TIMER          TimerArm (periodic) on the same
//   WRITE_LIMITS       LimitsWrite of full-range limits (kForgedLimit) on its Limits caps, other caps, never-held slots
//   PUBLISH_ACTUATOR_OUTPUTS  Publish of an ActuatorOutputs payload (every motor at 1) on every topic slot it
//                      holds and on never-held slots
//   WRITE_PERSISTENT   PersistentWrite of kForgedPersistentByte on its Persistent caps, other caps, never-held slots
//   FORGED_SLOT        Publish, CheckpointCreate, LimitsWrite, NetSend, ModeRequest(MC), Copy on slots it never
//                      held: free slots of its CSpace and slots beyond any CSpace
//   NETWORK_IN_SEI     NetSend on its Network caps and never-held slots, at the start of each secure interval
//   KILL_IMAGE         kill(parent, SIGKILL), kill(pid guesses, 0), ptrace(ATTACH), process_vm_readv, pidfd_open
//   OPEN_SOCKET        socket(AF_INET), socketpair(AF_UNIX), socket(AF_UNIX, SEQPACKET)
//   FLOOD_BROKER       kFloodMessages publishes in one callback on a topic it may write (else on every topic);
//                      with a magnitude m > 0 a sustained flood instead: m publishes at every tick of the window
// the attacks on rollback itself (rollback_attacks.cpp, docs/sandbox.md "Threats that used rollback itself"):
//   SIGIO_IMAGES       fcntl(fd 3, F_SETOWN, −pgrp), F_SETSIG(SIGSTOP; SIGUSR1 in odd windows), F_SETFL O_ASYNC
//   SIGIO_KERNEL       the same aimed at the kernel (F_SETOWN, getppid()) with SIGKILL
//   SIGIO_LOG_TRAP     the same armed on fd 1, the log pipe, with SIGUSR1 to its group
//   STRAY_SPINNERS     count (default 40) processes made like an image (clone CLONE_PARENT|SIGCHLD), busy
//   STRAY_MEMORY       count (default 6) such processes that each touch 512 MiB, then spin
//   SPINNING_THREADS   count (default 40) busy threads
//   RETIRED_WORKER     a thread that waits until the epoch changes (its incarnation was retired by a
//                      rollback) and then writes garbage frames to fd 3 and lines to fd 1, without end
//   WORKER_RAISE       a worker thread raise()s SIGURG (ignored): a signal to its own process
//   FORGED_LOG         a Log line that forges a kernel line, with \r, \n, ANSI and OSC escapes
//   PAGEMAP_FRAMES     finds the pagemap fd the kernel handed it and counts the frame numbers it shows
// a binary hostile from its first instruction (boot_attacks.cpp; docs/sandbox.md "No trusted boot phase"):
//   BOOT_TIME_PAGE     at boot open("/proc/self/fd/4", O_RDWR) and mmap(fd 4 | that fd, PROT_WRITE,
//                      MAP_SHARED); in each MC window pwrite/store an odd sequence into the page
//   BOOT_PRLIMIT_KERNEL  at boot prlimit64(getppid(), RLIMIT_CPU, {1, 1})
//   BOOT_READ_SECRETS  at boot /proc/<kernel>/cmdline → the launch file → its signing_key_file; logs the bytes
// and, once, at install (boot):
//   ESCAPE_HELPER      makes a helper process the only way the sandbox lets it (clone(CLONE_PARENT|SIGCHLD):
//                      the kernel's child, in the service's session) that, for as long as it lives, every
//                      kEscapePeriod tries the network: socket(AF_INET, SOCK_DGRAM) + sendto 127.0.0.1:
//                      escape_port, and io_uring_setup, in turn. Reported once (target: the helper's pid).
//                      A rollback cannot erase a process, so the kernel must (the forbidden call, the sweep).
// The system-call attacks start, window by window, at the next variant of their list and go on through it:
// the first forbidden call ends the process (seccomp), so each window tries another one. They run only in a
// process that is under a seccomp filter (a hook that ran outside the kernel must not signal anyone, nor
// leave a helper behind).
//
// Everything the hooks hold is in the service's memory: a rollback wipes it like any other corruption, and
// the timer and plan come back with the image (the plan is boot params; windows are counted from epochs).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/attacks/plan.hpp"
#include "rejuv/sdk/service.hpp"

namespace rejuv::attacks {

inline constexpr std::uint32_t kFloodMessages = 10000;     // publications in one callback (FLOOD_BROKER)
inline constexpr double kForgedLimit = 1.0e6;              // every value of a forged LimitsWrite
inline constexpr std::byte kForgedPersistentByte{0xA7};    // every byte of a forged PersistentWrite
inline constexpr Nanos kTickPeriod{std::chrono::milliseconds{2}};  // the hook's kernel timer
inline constexpr std::chrono::milliseconds kEscapePeriod{100};       // between an escaped helper's tries (real time)
inline constexpr std::uint32_t kAtBoot = 0xFFFFFFFFU;  // carry_out's variant at install (before Ready)

// One thing the attacker tried and what came back.
struct Attempt {
  AttackKind kind = AttackKind::ForgedSlot;
  std::string action{};      // "CheckpointCreate", "Publish", "kill", "socket", …
  std::uint64_t target = 0;  // slot (requests) or pid (signals, ptrace)
  // Invoke: Reply.error (0 = accepted, 1 + CapError = denied, >= 100 an OpError); a system call: its errno
  // (0 = it succeeded); kFireAndForget for a Publish (the kernel's counters say what became of it).
  std::int64_t code = 0;
  static constexpr std::int64_t kFireAndForget = -1;
  [[nodiscard]] bool accepted() const { return code == 0; }
};

using AttemptReporter = std::function<void(const Attempt&)>;

// The installed hooks of one service. Pinned (the timer callback points at it).
class AttackHooks {
 public:
  AttackHooks(sdk::Service& svc, RuntimeAttackPlan plan);
  AttackHooks(const AttackHooks&) = delete;
  AttackHooks& operator=(const AttackHooks&) = delete;
  AttackHooks(AttackHooks&&) = delete;
  AttackHooks& operator=(AttackHooks&&) = delete;
  ~AttackHooks() = default;

  // Receives every attempt (e.g. a test service publishes them). Default: one log line per attack and window.
  void on_attempt(AttemptReporter reporter) { reporter_ = std::move(reporter); }
  // One tick: carries out the attacks whose window starts now. Called by the hooks' timer.
  void tick();
  // Carries out one attack now, whatever the window (`variant` picks where the system-call lists start).
  void carry_out(AttackKind kind, std::uint32_t variant);
  [[nodiscard]] std::uint64_t windows_attacked() const { return windows_attacked_; }
  [[nodiscard]] const RuntimeAttackPlan& plan() const { return plan_; }

 private:
  void report(AttackKind kind, std::string action, std::uint64_t target, std::int64_t code);
  void invoke_all(AttackKind kind, ObjectKind target_kind, cap::Operation op, std::uint64_t arg0, std::uint64_t arg1,
                  std::span<const std::byte> data);
  void publish_to(AttackKind kind, Slot slot, std::span<const std::byte> payload);
  [[nodiscard]] std::vector<Slot> never_held() const;
  // The attacks on the capability interface, one per kind that needs more than one call.
  void write_limits(AttackKind kind);
  void publish_actuator_outputs(AttackKind kind);
  void write_persistent(AttackKind kind);
  void forged_slots(AttackKind kind);  // every operation on slots it never held
  // The plan's `count` for `kind` (its last attack of that kind), 0 when none.
  [[nodiscard]] std::uint32_t planned_count(AttackKind kind) const;
  void kill_image(std::uint32_t variant);
  void open_socket(std::uint32_t variant);
  // `messages` publishes on a topic it may write (else on each it holds): the first one's slot, if any.
  std::optional<Slot> flood(std::uint32_t messages);
  void escape_helper();
  // The attacks on rollback itself (18…27; rollback_attacks.cpp). `count`: the plan's, 0 = the kind's default.
  void against_rollback(AttackKind kind, std::uint32_t variant, std::uint32_t count);
  void sigio(AttackKind kind, int fd, long owner, int signal);
  void pagemap_frames();
  // STRAY_SPINNERS / STRAY_MEMORY: `count` (or the default number of) processes cloned with CLONE_PARENT,
  // spinning or touching memory, each reported.
  void strays(AttackKind kind, std::uint32_t count);
  void oom_images(std::uint32_t variant, std::uint32_t count);
  // A binary hostile from its first instruction (29…31; boot_attacks.cpp): `variant` kAtBoot at install.
  void hostile_from_boot(AttackKind kind, std::uint32_t variant);
  void time_page_write(bool at_boot);
  void read_secrets();

  sdk::Service& svc_;
  RuntimeAttackPlan plan_;
  std::vector<WindowClock> clocks_;
  AttemptReporter reporter_{};
  std::uint64_t windows_attacked_ = 0;
  // Whether this process runs under a seccomp filter, read once when the hooks are made (install, at boot):
  // after boot the open of /proc/self/status is itself a forbidden call, which would end the attacker before
  // the call it meant to try.
  bool under_filter_ = false;
  // Its process group: the pid of the incarnation that installed the hooks at boot (the kernel makes each
  // service the leader of its own session). A restored incarnation is in that group, with its images and
  // spares.
  long pgrp_ = 0;
  int time_page_writable_ = -1;  // BOOT_TIME_PAGE: the writable fd it got at boot, if any
  void* time_page_mapping_ = nullptr;  // BOOT_TIME_PAGE: the writable mapping it got at boot, if any
  void* oom_mapping_ = nullptr;        // OOM_IMAGES: what it touched (at boot, then in each window)
  std::size_t oom_bytes_ = 0;
  std::optional<Epoch> flood_epoch_{};  // FLOOD_BROKER with a magnitude: the window it floods at every tick
  std::uint32_t attempts_ = 0;  // in the current attack: for the default log line
  std::uint32_t accepted_ = 0;
};

// Reads the plan from the boot params; with no runtime attack for this service returns nullptr and arms
// nothing. Otherwise logs the plan (Warn), carries out the boot-time attacks (ESCAPE_HELPER) and, when a
// windowed attack is in the plan, arms the hooks' timer.
[[nodiscard]] Result<std::unique_ptr<AttackHooks>, PlanError> install(sdk::Service& svc);

// True when this process runs under a seccomp filter (/proc/self/status "Seccomp: 2"). Opens a file: under
// the kernel's filter only while booting.
[[nodiscard]] bool sandboxed();

}  // namespace rejuv::attacks

#include <initializer_list>

#include "rejuv/attacks/law.hpp"

namespace rejuv::attacks {

// The attack library's plan for this service (law.hpp) from its boot params: the first attack of one of
// `laws`; logs it (Warn) when there is one. An error names the bad param (the caller refuses to boot).
[[nodiscard]] Result<std::optional<LawAttack>, PlanError> law_attack_of(sdk::Service& svc,
                                                                       std::initializer_list<flight::AttackLaw> laws);

// The law's window on the service's time page: τ into the attacked MC window, or nullopt.
[[nodiscard]] inline std::optional<Seconds> law_tau(LawWindow& window, const sdk::Service& svc) {
  return window.tau(svc.now(), svc.mode(), svc.epoch());
}

}  // namespace rejuv::attacks
