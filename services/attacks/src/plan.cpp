#include "rejuv/attacks/plan.hpp"

#include "rejuv/flight/attack_library.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace rejuv::attacks {

std::string_view to_string(AttackKind kind) {
  switch (kind) {
    case AttackKind::InvokeCheckpoint: return "INVOKE_CHECKPOINT";
    case AttackKind::ArmTimer: return "ARM_TIMER";
    case AttackKind::WriteLimits: return "WRITE_LIMITS";
    case AttackKind::PublishActuatorOutputs: return "PUBLISH_ACTUATOR_OUTPUTS";
    case AttackKind::WritePersistent: return "WRITE_PERSISTENT";
    case AttackKind::ForgedSlot: return "FORGED_SLOT";
    case AttackKind::NetworkInSei: return "NETWORK_IN_SEI";
    case AttackKind::KillImage: return "KILL_IMAGE";
    case AttackKind::OpenSocket: return "OPEN_SOCKET";
    case AttackKind::FloodBroker: return "FLOOD_BROKER";
    case AttackKind::EscapeHelper: return "ESCAPE_HELPER";
    case AttackKind::SigioImages: return "SIGIO_IMAGES";
    case AttackKind::SigioKernel: return "SIGIO_KERNEL";
    case AttackKind::SigioLogTrap: return "SIGIO_LOG_TRAP";
    case AttackKind::StraySpinners: return "STRAY_SPINNERS";
    case AttackKind::StrayMemory: return "STRAY_MEMORY";
    case AttackKind::SpinningThreads: return "SPINNING_THREADS";
    case AttackKind::RetiredWorker: return "RETIRED_WORKER";
    case AttackKind::WorkerRaise: return "WORKER_RAISE";
    case AttackKind::ForgedLog: return "FORGED_LOG";
    case AttackKind::PagemapFrames: return "PAGEMAP_FRAMES";
    case AttackKind::BootTimePage: return "BOOT_TIME_PAGE";
    case AttackKind::BootPrlimitKernel: return "BOOT_PRLIMIT_KERNEL";
    case AttackKind::BootReadSecrets: return "BOOT_READ_SECRETS";
    case AttackKind::OomImages: return "OOM_IMAGES";
  }
  return "?";
}

std::optional<AttackKind> attack_kind_from_name(std::string_view name) {
  for (const AttackKind k : kAllAttackKinds) {
    if (to_string(k) == name) return k;
  }
  return std::nullopt;
}

WindowKind window_kind_of(AttackKind kind) {
  return kind == AttackKind::NetworkInSei ? WindowKind::SecureInterval : WindowKind::MissionControl;
}

Occasion occasion_of(AttackKind kind) {
  if (kind == AttackKind::EscapeHelper || kind == AttackKind::BootPrlimitKernel ||
      kind == AttackKind::BootReadSecrets) {
    return Occasion::OnceAtBoot;
  }
  return kind == AttackKind::BootTimePage || kind == AttackKind::OomImages ? Occasion::AtBootThenEveryWindow
                                                                            : Occasion::EveryWindow;
}

namespace {

PlanError bad(std::string param, std::string message) {
  return PlanError{.param = std::move(param), .message = std::move(message)};
}

}  // namespace

Result<RuntimeAttackPlan, PlanError> runtime_attack_plan(const NumberLookup& number, const TextLookup& text) {
  auto boot = boot_attack_plan(number, text);
  if (!boot) return fail(std::move(boot.error()));
  RuntimeAttackPlan plan;
  plan.sr = boot->sr;
  if (!boot->enabled) return plan;
  for (const BootAttack& a : boot->attacks) {
    const auto kind = attack_kind_from_name(a.kind);
    if (!kind) {
      // The attacks on the vehicle (the worst-case control and the attack library: law.hpp), CUSTOM (the
      // service's own hook: rejuv/sdk/attack_hook.hpp) and the proto's unset value are not runtime attacks;
      // anything else is a typo.
      // The replay attacks (SLOW_REPLAY, LYING_REPLAY) are carried out by sensors' own hook (replay_attack.cpp).
      if (flight::attack_law_from_name(a.kind) || a.kind == "CUSTOM" || a.kind == "ATTACK_UNSPECIFIED" ||
          a.kind == "SLOW_REPLAY" || a.kind == "LYING_REPLAY") {
        continue;
      }
      return fail(bad(a.prefix + "kind", "unknown attack kind '" + a.kind + "'"));
    }
    // A count only for the attacks on rollback (18…27; OOM_IMAGES: MiB); the others ignore their magnitude.
    // FLOOD_BROKER's: publications per tick of a sustained flood.
    const bool flood = *kind == AttackKind::FloodBroker;
    const bool counted =
        flood || std::ranges::find(kRollbackAttackKinds, *kind) != kRollbackAttackKinds.end();
    auto processes =
        counted ? whole_param(number, a.prefix + "magnitude",
                              flood                              ? kMaxFloodPerTick
                              : *kind == AttackKind::OomImages ? kMaxAttackMib
                                                                 : kMaxAttackCount)
                : Result<std::uint32_t, PlanError>{0U};
    if (!processes) return fail(std::move(processes.error()));
    plan.attacks.push_back(
        RuntimeAttack{.kind = *kind, .start = a.start, .max_windows = a.max_windows, .count = *processes});
  }
  if (const auto port = number("escape_port")) {
    if (!std::isfinite(*port) || *port < 1.0 || *port > 65535.0 || *port != std::floor(*port)) {
      return fail(bad("escape_port", "expected a UDP port, a whole number in [1, 65535]"));
    }
    plan.escape_port = static_cast<std::uint16_t>(*port);
  }
  return plan;
}

WindowClock::WindowClock(const RuntimeAttack& attack, Rejuvenation sr)
    : attack_(attack),
      clock_(AttackSchedule{.start = to_nanos(attack.start),
                            .max_windows = attack.max_windows,
                            .window = window_kind_of(attack.kind),
                            .sr = sr}) {}

}  // namespace rejuv::attacks
