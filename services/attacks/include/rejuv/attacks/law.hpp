// The attack library's runtime side (docs/control.md "Attack library"): which law of
// flight/attack_library.hpp a compromised service carries out, from the boot params (attack.<j>.kind,
// start_s, max_windows, magnitude; sr.enabled), and when it acts: in attacked MC windows, decided like every
// windowed attack by the rollback epochs (plan.hpp WindowClock), so that a restored image knows which window
// it is in. The hook that uses it lives in the compromised service (ekf2, sensors, gen_set_point, lqr_control)
// and keeps its corruption in that service's memory: the rollback to the clean image erases it.
// Test builds only (REJUV_ATTACK_HOOKS), like the rest of services/attacks.
#pragma once

#include <initializer_list>
#include <optional>

#include "rejuv/attacks/plan.hpp"
#include "rejuv/flight/attack_library.hpp"

namespace rejuv::attacks {

struct LawAttack {
  flight::AttackLaw law = flight::AttackLaw::WorstCaseControl;
  Seconds start{0.0};
  std::uint32_t max_windows = 0;  // 0 = every MC window
  double magnitude = 0.0;         // effective (the kind's default when the plan says 0)
  Rejuvenation sr = Rejuvenation::On;
};

// The first attack of the boot params whose kind is one of `laws`; nullopt when attacks are off or there is
// none. A negative or non-finite start or magnitude, or a max_windows that is not a whole number, is an error.
[[nodiscard]] Result<std::optional<LawAttack>, PlanError> law_attack_plan(const NumberLookup& number,
                                                                         const TextLookup& text,
                                                                         std::initializer_list<flight::AttackLaw> laws);

// When the law acts. tau() is called on every step of the compromised service with the time page.
class LawWindow {
 public:
  explicit LawWindow(const LawAttack& attack);
  // τ since the attacked window began (without SR: since the attack began), or nullopt outside one.
  [[nodiscard]] std::optional<Seconds> tau(Nanos now, SrMode mode, Epoch epoch);
  // True at the first step of an attacked window (after tau() of that step).
  [[nodiscard]] bool began_now() const { return began_now_; }
  [[nodiscard]] const LawAttack& attack() const { return attack_; }

 private:
  LawAttack attack_;
  WindowClock clock_;
  std::optional<Epoch> active_epoch_{};
  Nanos began_{0};
  bool began_now_ = false;
};

}  // namespace rejuv::attacks
