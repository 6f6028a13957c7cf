// The worst-case control attack of §VI-D (launch attack kind WORST_CASE_CONTROL) for lqr_control's attack
// hook (docs/design.md §9). Test builds only: everything here exists only with REJUV_ATTACK_HOOKS.
//
// What it does, as the simulation's attacker (flight/sim sr_sim.cpp): from the start of every MC window at or
// after `start`, for at most `max_windows` windows (0 = all), the compromised controller publishes the corner
// of Ū that maximises d/dt ‖x − x_sp‖²_P, evaluated with its own x̂ (flight::worst_case_corner); otherwise the
// honest u. Without SR the one MC window never ends: the attack starts once now ≥ start and stays.
//
// Counting windows across rollbacks. The simulation's attacker lives outside the software image; this one
// lives inside lqr_control, which every rollback restores to its checkpoint, so a counter in memory would
// restart with every window. What survives a rollback is the time page (now, mode, epoch) and whatever the
// process held when its image was taken, in CP. With SR each MC window is the window of one epoch (the timer
// is armed once per epoch), so the attack records, in the SEI, the first epoch whose SEI saw now ≥ start;
// that record is part of every later image, and the window of epoch E is attacked iff E − first <
// max_windows. (A window whose start falls between the last SEI control step and MC — a few ms — is not
// attacked: the record needs the SEI.)
#pragma once

#if defined(REJUV_ATTACK_HOOKS)

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight_io/params.hpp"

namespace rejuv::services {

// The attack of the launch graph's plan that names this service (boot params attack.*).
struct WorstCaseAttackPlan {
  Seconds start{0};               // first MC window at or after this time
  std::uint32_t max_windows = 0;  // 0 = every MC window
  flight::SrSwitch sr = flight::SrSwitch::On;
};

// Reads attack.enabled, attack.count and attack.<j>.{kind, start_s, max_windows} (the kernel passes only the
// attacks naming this service; kind is a text param, read through `text`, "" when absent) and sr.enabled.
// nullopt when the plan is off or has no WORST_CASE_CONTROL attack; the first such attack is used, as
// flight::config_from_launch does.
using TextParam = std::function<std::string(std::string_view name)>;
[[nodiscard]] Result<std::optional<WorstCaseAttackPlan>, flight_io::InputFailure> worst_case_attack_plan(
    const flight_io::Params& numbers, const TextParam& text);

class WorstCaseAttack {
 public:
  WorstCaseAttack(const WorstCaseAttackPlan& plan, const flight::ControlDesign& design);

  // The decision for one control step, from the time page: true when this step's controls are forged.
  [[nodiscard]] bool decide(Nanos now, SrMode mode, Epoch epoch);
  // decide() and, when it says so, the worst-case corner of Ū for x̂ and x_sp (the hook's body).
  [[nodiscard]] std::optional<flight::InputVec> on_control(Nanos now, SrMode mode, Epoch epoch,
                                                           const flight::StateVec& x_hat,
                                                           const flight::StateVec& x_sp);
  // The corner itself (flight::worst_case_corner on Ū, P and the continuous B, as the simulation).
  [[nodiscard]] flight::InputVec corner(const flight::StateVec& x_hat, const flight::StateVec& x_sp) const;

  // Windows this incarnation has attacked (a rollback restores the count of the image: for logs only).
  [[nodiscard]] std::uint64_t windows_attacked() const { return windows_attacked_; }
  [[nodiscard]] const std::optional<Epoch>& first_epoch() const { return first_epoch_; }

 private:
  WorstCaseAttackPlan plan_;
  flight::InputBox restricted_;
  flight::StateMat P_;
  flight::InputMat B_;
  std::optional<Epoch> first_epoch_;   // recorded in the SEI: the first epoch that saw now ≥ start
  std::optional<Epoch> window_epoch_;  // the MC window decided last
  bool window_attacked_ = false;
  std::uint64_t windows_attacked_ = 0;
};

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
