// The CUSTOM attack hook (idl/launch.proto AttackKind CUSTOM; docs/writing_a_service.md "Injecting a fault
// into your own service"): how any SDK service lets the launch plan inject a fault of its author's own — a
// gain overwritten, a stuck output, a bad estimate — in the windows the kernel's plan decides, exactly as for
// the project's own attack kinds (start_s, max_windows; MC windows only; rejuv/core/attack_window.hpp). What
// the fault is stays in the service's memory, so a rollback erases it like any corruption: that is what a
// test of the service under SR shows.
//
// Test builds only: this header refuses to compile unless REJUV_ATTACK_HOOKS is defined, which linking the
// library Rejuv::sdk_attack (rejuv_add_service(... ATTACK_HOOKS), or -DREJUV_ATTACK_HOOKS=ON for every
// service of the project) does. A service's own code keeps the hook behind the same macro:
//
//   #if defined(REJUV_ATTACK_HOOKS)
//   #include "rejuv/sdk/attack_hook.hpp"
//   #endif
//   ...
//   #if defined(REJUV_ATTACK_HOOKS)
//     auto attack = rejuv::sdk::on_attack(svc, [&](const rejuv::sdk::AttackWindow& w) {
//       gain = -w.magnitude * gain;                  // the fault, at the start of each attacked window
//     });
//     if (!svc.require(attack, "attack plan")) return 1;
//   #endif
//
// A launch plan then names the service: attack { enabled: true attacks { kind: CUSTOM service: "mine"
// start_s: 5 max_windows: 3 magnitude: 2 } }. Not members of Service: the SDK itself is built once, without
// hooks, for every service.
#pragma once

#if !defined(REJUV_ATTACK_HOOKS)
#error \
    "rejuv/sdk/attack_hook.hpp is for test builds: link Rejuv::sdk_attack (rejuv_add_service(... ATTACK_HOOKS)), which defines REJUV_ATTACK_HOOKS"
#endif

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "rejuv/core/attack_window.hpp"
#include "rejuv/sdk/service.hpp"

namespace rejuv::sdk {

// One attacked window of a CUSTOM attack.
struct AttackWindow {
  std::uint32_t attack = 0;   // which CUSTOM attack of the plan naming this service (0 = the first)
  std::uint32_t ordinal = 0;  // which of its windows (0 = the first)
  Epoch epoch{};              // the rollback epoch whose MC window it is
  Nanos began{0};             // kernel time at which the hook saw it begin
  double magnitude = 0;       // the plan's magnitude, as written (0 when unset; its meaning is the author's)
};

// The installed CUSTOM hook of one service. Pinned (its timer callback points at it); lives as long as the
// event loop, like every handle of the service.
class CustomAttack {
 public:
  // Reads the launch plan from the boot params (attack.enabled, attack.count, attack.<j>.kind, start_s,
  // max_windows, magnitude; sr.enabled) and keeps the CUSTOM attacks that name this service. None (attacks
  // off, `rejuv run --no-attack`, another service named): nullptr, and nothing is armed. Otherwise logs the
  // plan (Warn) and arms one kernel timer (kTick) that watches the time page, so that `on_window` runs once
  // at the start of every attacked window, in the event loop like every callback. A malformed param is
  // BadArgument naming it.
  [[nodiscard]] static SdkResult<std::unique_ptr<CustomAttack>> install(
      Service& svc, std::function<void(const AttackWindow&)> on_window);

  static constexpr Nanos kTick{std::chrono::milliseconds{2}};

  CustomAttack(Service& svc, std::vector<std::pair<AttackWindowClock, double>> clocks,
               std::function<void(const AttackWindow&)> on_window);
  CustomAttack(const CustomAttack&) = delete;
  CustomAttack& operator=(const CustomAttack&) = delete;
  CustomAttack(CustomAttack&&) = delete;
  CustomAttack& operator=(CustomAttack&&) = delete;
  ~CustomAttack() = default;

  // The attacked window in force now (time page), or nullopt: for a fault that lasts the whole window, read
  // it in the service's own callbacks. Looks at the time page first, so a window that begins now is seen
  // (and on_window runs) even before the hook's next tick.
  [[nodiscard]] std::optional<AttackWindow> window();
  [[nodiscard]] bool active() { return window().has_value(); }
  // Windows begun in this process's memory (a rollback takes it back to the image's count).
  [[nodiscard]] std::uint64_t windows() const { return windows_; }
  // Called by the hook's timer: runs on_window for each attack whose window begins now.
  void tick();

 private:
  Service& svc_;
  std::vector<std::pair<AttackWindowClock, double>> clocks_;  // one per CUSTOM attack, with its magnitude
  std::function<void(const AttackWindow&)> on_window_;
  std::vector<std::optional<AttackWindow>> current_;  // the window each attack began last
  std::uint64_t windows_ = 0;
};

// CustomAttack::install: `svc`'s CUSTOM attacks, `fn` at the start of each attacked window.
[[nodiscard]] inline SdkResult<std::unique_ptr<CustomAttack>> on_attack(
    Service& svc, std::function<void(const AttackWindow&)> fn) {
  return CustomAttack::install(svc, std::move(fn));
}

}  // namespace rejuv::sdk
