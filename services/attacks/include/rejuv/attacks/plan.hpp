// The runtime part of the launch graph's attack plan (idl/launch.proto AttackKind 2…12, 18…27; docs/design.md §9, §11):
// which attacks a compromised service carries out against the runtime, from when, in how many windows, and
// when a window starts. Built from the service's boot params (attack.enabled, attack.count,
// attack.<j>.kind (text), attack.<j>.start_s, attack.<j>.max_windows; docs/protocol.md "Boot params"), and
// the service param escape_port (ESCAPE_HELPER's target). ESCAPE_HELPER is carried out once, at boot, not
// per window (its start_s and max_windows are ignored).
// WORST_CASE_CONTROL (kind 1) and the attack library (13–17, law.hpp) act on the vehicle and are skipped here.
//
// Everything here lives in the service's memory, so a rollback wipes it like any other corruption; the
// windows are counted from rollback epochs (kernel state on the time page), so a restored image knows which
// window it is in without remembering anything (the idea of lqr_control's WorstCaseAttack).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/attack_window.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::attacks {

// The runtime attacks of idl/launch.proto AttackKind (same numbers and names).
enum class AttackKind : std::uint8_t {
  InvokeCheckpoint = 2,        // CheckpointCreate / CheckpointRollback in MC
  ArmTimer = 3,                // arm the rejuvenation timer in MC
  WriteLimits = 4,             // write the actuator limits in MC
  PublishActuatorOutputs = 5,  // publish motor outputs directly (an ActuatorOutputs payload on any slot)
  WritePersistent = 6,         // write a Persistent cell in MC
  ForgedSlot = 7,              // requests on slots never held (beyond the CSpace, empty ones)
  NetworkInSei = 8,            // send on the network during the secure interval
  KillImage = 9,               // kill / ptrace / process_vm_readv other processes (its images, its parent)
  OpenSocket = 10,             // socket(), socketpair()
  FloodBroker = 11,            // thousands of publishes in one callback
  EscapeHelper = 12,           // once at boot: a helper process that keeps trying the network (UDP, io_uring)
  // Attacks on rollback itself (rollback_attacks.cpp): 18…27.
  SigioImages = 18,            // SIGIO aimed at its process group (its images): SIGSTOP, SIGUSR1
  SigioKernel = 19,            // SIGIO aimed at the kernel with SIGKILL
  SigioLogTrap = 20,           // SIGIO armed on the log pipe, to fire in a restored incarnation
  StraySpinners = 21,          // busy processes made like an image (default 40 per window)
  StrayMemory = 22,            // processes that each touch 512 MiB (default 6 per window)
  SpinningThreads = 23,        // busy threads (default 40 per window)
  RetiredWorker = 24,          // a thread that acts once its incarnation is retired (garbage frames and lines)
  WorkerRaise = 25,            // raise() from a worker thread (not a violation: the kernel must not kill it)
  ForgedLog = 26,              // a Log frame forging a kernel line, with control characters and escapes
  PagemapFrames = 27,          // reads the pagemap it was handed: the physical frame numbers it can see
  // A binary hostile from its first instruction (boot_attacks.cpp): 29…31.
  BootTimePage = 29,           // at boot a writable handle on the time page; in MC an odd sequence written
  BootPrlimitKernel = 30,      // at boot prlimit64(kernel, RLIMIT_CPU, {1, 1})
  BootReadSecrets = 31,        // at boot /proc/<kernel>/cmdline → the launch file → the signing key
  // Against rollback again (rollback_attacks.cpp): 32.
  OomImages = 32,              // at boot m MiB touched (in every image); in MC unmapped and 1.5·m MiB touched
};
inline constexpr std::array kAllAttackKinds{
    AttackKind::InvokeCheckpoint, AttackKind::ArmTimer,     AttackKind::WriteLimits,
    AttackKind::PublishActuatorOutputs, AttackKind::WritePersistent, AttackKind::ForgedSlot,
    AttackKind::NetworkInSei,     AttackKind::KillImage,    AttackKind::OpenSocket,
    AttackKind::FloodBroker,      AttackKind::EscapeHelper, AttackKind::SigioImages,
    AttackKind::SigioKernel,      AttackKind::SigioLogTrap, AttackKind::StraySpinners,
    AttackKind::StrayMemory,      AttackKind::SpinningThreads, AttackKind::RetiredWorker,
    AttackKind::WorkerRaise,      AttackKind::ForgedLog,    AttackKind::PagemapFrames,
    AttackKind::BootTimePage,     AttackKind::BootPrlimitKernel, AttackKind::BootReadSecrets,
    AttackKind::OomImages};
// The kinds that attack rollback itself (18…27, 32), in the order of docs/sandbox.md's threat table.
inline constexpr std::array kRollbackAttackKinds{
    AttackKind::SigioImages,   AttackKind::SigioKernel,     AttackKind::SigioLogTrap, AttackKind::StraySpinners,
    AttackKind::StrayMemory,   AttackKind::OomImages,       AttackKind::SpinningThreads, AttackKind::RetiredWorker,
    AttackKind::WorkerRaise,   AttackKind::ForgedLog,       AttackKind::PagemapFrames};
// The kinds of a binary hostile from its first instruction (29…31), in the order of docs/sandbox.md's table.
inline constexpr std::array kBootAttackKinds{AttackKind::BootTimePage, AttackKind::BootPrlimitKernel,
                                             AttackKind::BootReadSecrets};
// The AttackKind enum name of idl/launch.proto, e.g. "INVOKE_CHECKPOINT".
[[nodiscard]] std::string_view to_string(AttackKind kind);
// The kind named `name` (the proto enum name); nullopt for anything that is not a runtime attack.
[[nodiscard]] std::optional<AttackKind> attack_kind_from_name(std::string_view name);

// Which windows an attack acts in: MC windows, or (NETWORK_IN_SEI) the secure intervals.
using WindowKind = rejuv::AttackWindowKind;  // rejuv/core/attack_window.hpp
[[nodiscard]] WindowKind window_kind_of(AttackKind kind);

// When an attack is carried out: at the start of its windows (WindowClock), or once when the hooks are
// installed, at boot (ESCAPE_HELPER: what it leaves behind must outlive the boot to matter).
// EveryWindow: at the first tick of each attacked window. OnceAtBoot: once, at install (before Ready).
// AtBootThenEveryWindow: both (a boot step that prepares what each window uses: BOOT_TIME_PAGE).
enum class Occasion : std::uint8_t { EveryWindow, OnceAtBoot, AtBootThenEveryWindow };
[[nodiscard]] Occasion occasion_of(AttackKind kind);

// The largest count an attack on rollback takes (attack.<j>.magnitude; the launch loader checks it too).
inline constexpr double kMaxAttackCount = 1000.0;
// OOM_IMAGES's magnitude: MiB touched at boot, not a count.
inline constexpr double kMaxAttackMib = 65536.0;
// The largest FLOOD_BROKER magnitude: publications per tick of a sustained flood (the launch loader checks it too).
inline constexpr double kMaxFloodPerTick = 100000.0;

// ESCAPE_HELPER's UDP target port on 127.0.0.1 when the service has no escape_port param (discard).
inline constexpr std::uint16_t kDefaultEscapePort = 9;

using Rejuvenation = rejuv::Rejuvenation;

struct RuntimeAttack {
  AttackKind kind = AttackKind::ForgedSlot;
  Seconds start{0.0};             // first window that starts at or after this time
  std::uint32_t max_windows = 0;  // 0 = every window
  std::uint32_t count = 0;        // attack.<j>.magnitude: how many processes or threads (18…27); 0 = the default
};

struct RuntimeAttackPlan {
  std::vector<RuntimeAttack> attacks{};
  Rejuvenation sr = Rejuvenation::On;
  std::uint16_t escape_port = kDefaultEscapePort;  // service param escape_port (ESCAPE_HELPER)
};

// A malformed attack param, and the param lookups: the plan reader's (rejuv/core/attack_window.hpp).
using PlanError = AttackParamError;
using ::rejuv::NumberLookup;
using ::rejuv::TextLookup;

// The runtime attacks of the boot params, in plan order; empty when attacks are off or none is a runtime
// attack. An unknown kind name, a negative or non-finite start, a count/max_windows that is not a whole
// number, or an escape_port that is not a whole number in [1, 65535] is an error (bad input never aborts,
// docs/conventions.md).
[[nodiscard]] Result<RuntimeAttackPlan, PlanError> runtime_attack_plan(const NumberLookup& number,
                                                                       const TextLookup& text);

// Decides, callback by callback, whether a window of the attack's kind starts now and is to be attacked: the
// rule of rejuv/core/attack_window.hpp (AttackWindowClock), which the run summary counts windows by too.
class WindowClock {
 public:
  WindowClock(const RuntimeAttack& attack, Rejuvenation sr);
  // True exactly once, at the first call of a window that is to be attacked.
  [[nodiscard]] bool begins(Nanos now, SrMode mode, Epoch epoch) { return clock_.begins(now, mode, epoch); }
  // Ordinal of the window last attacked (0 = the first), e.g. to vary an attack from window to window.
  [[nodiscard]] std::uint32_t ordinal() const { return clock_.ordinal(); }
  [[nodiscard]] const RuntimeAttack& attack() const { return attack_; }

 private:
  RuntimeAttack attack_;
  AttackWindowClock clock_;  // the one rule (rejuv/core/attack_window.hpp)
};

}  // namespace rejuv::attacks
