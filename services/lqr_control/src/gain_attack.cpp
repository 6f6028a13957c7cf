#include "rejuv/services/lqr_control/mission_control.hpp"

#if defined(REJUV_ATTACK_HOOKS)

#include <memory>

#include "rejuv/attacks/hooks.hpp"
#include "rejuv/sdk/service.hpp"

namespace rejuv::services {

bool arm_library_attack(sdk::Service& svc, MissionControl& control) {
  auto plan = attacks::law_attack_of(svc, {flight::AttackLaw::GainOverwrite});
  if (!svc.require(plan, "bad attack params")) return false;
  if (!*plan) return true;
  auto window = std::make_shared<attacks::LawWindow>(**plan);
  const flight::GainMat K = flight::overwritten_gain(control.controller().K(), window->attack().magnitude);
  control.set_gain_hook([&svc, window, K]() -> std::optional<flight::GainMat> {
    if (!attacks::law_tau(*window, svc) || !window->began_now()) return std::nullopt;
    return K;  // once, at the window's first step: from then on the object holds it
  });
  return true;
}

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
