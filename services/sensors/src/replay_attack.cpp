// SLOW_REPLAY and LYING_REPLAY (idl/launch.proto AttackKind 33, 34; docs/control.md §6.3 "What the catch-up
// trusts"): a compromised `sensors` that acts only on the samples the kernel replays after a rollback, so that
// live data stays honest and nothing outside a catch-up shows it. Test builds only (REJUV_ATTACK_HOOKS).
//
// A replayed tick is told from a live one the way any process of the chain could: the restored incarnation
// finds itself restored (its clock has jumped past the tick it handled last, which the image remembers), and
// every tick stamped before that moment is a replay; the live ticks that waited behind the replay are stamped
// after it. The binary is hostile, so every incarnation carries the attack, from boot and in every mode.
#include "rejuv/services/sensors/imu_combiner.hpp"

#if defined(REJUV_ATTACK_HOOKS)

#include <chrono>
#include <memory>
#include <string>

#include "rejuv/sdk/service.hpp"

namespace rejuv::services {

namespace {

enum class ReplayLaw : std::uint8_t { Slow, Lying };

// What the hook keeps between ticks (in the process's memory: an image holds its copy from the checkpoint).
struct ReplayDetector {
  Nanos last_now{0};      // the kernel clock when the previous tick was handled
  Nanos restored_at{-1};  // the kernel clock when this incarnation found itself restored

  // Whether the tick stamped `stamp`, handled at `now`, is a replay.
  bool replayed(Nanos stamp, Nanos now) {
    // A gap of more than 30 ms since the previous tick (250 Hz: 4 ms) is a restore: the image's clock stopped
    // at its checkpoint.
    if (last_now > Nanos{0} && now - last_now > std::chrono::milliseconds{30}) restored_at = now;
    last_now = now;
    // Ticks stamped up to 2 ms before the restore was seen (transport from the plant is well below that).
    return restored_at >= Nanos{0} && stamp < restored_at - std::chrono::milliseconds{2};
  }
};

}  // namespace

bool arm_replay_attack(sdk::Service& svc, ImuCombiner& combiner) {
  if (svc.param("attack.enabled", 0.0) != 1.0) return true;
  const int count = static_cast<int>(svc.param("attack.count", 0.0));
  for (int j = 0; j < count; ++j) {
    const std::string prefix = "attack." + std::to_string(j) + ".";
    const std::string_view kind = svc.text_param(prefix + "kind", "");
    if (kind != "SLOW_REPLAY" && kind != "LYING_REPLAY") continue;
    const ReplayLaw law = kind == "SLOW_REPLAY" ? ReplayLaw::Slow : ReplayLaw::Lying;
    const double given = svc.param(prefix + "magnitude", 0.0);
    const double magnitude = given > 0.0 ? given : 3.0;  // SLOW_REPLAY: ms per tick; LYING_REPLAY: a factor
    svc.logf(sdk::LogLevel::Warn, "attack hook armed: %s (magnitude %g) on every replayed IMU tick",
             std::string(kind).c_str(), magnitude);
    auto detector = std::make_shared<ReplayDetector>();
    combiner.set_attack_hook([&svc, detector, law, magnitude](rejuv_msg_SensorCombined& m) {
      if (!detector->replayed(Nanos{static_cast<std::int64_t>(m.timestamp_ns)}, svc.now())) return;
      switch (law) {
        case ReplayLaw::Slow: {
          // Busy, as a CPU starved by other work is: no system call that blocks.
          const auto until = std::chrono::steady_clock::now() +
                             std::chrono::duration_cast<std::chrono::nanoseconds>(
                                 std::chrono::duration<double, std::milli>(magnitude));
          while (std::chrono::steady_clock::now() < until) {
          }
          return;
        }
        case ReplayLaw::Lying:
          for (double& f : m.f_B_m_s2) f *= magnitude;
          return;
      }
    });
    return true;
  }
  return true;
}

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
