#include "rejuv/services/gen_set_point/setpoint_node.hpp"

#if defined(REJUV_ATTACK_HOOKS)

#include <memory>

#include "rejuv/attacks/hooks.hpp"
#include "rejuv/sdk/service.hpp"

namespace rejuv::services {

bool arm_library_attack(sdk::Service& svc, SetpointNode& node) {
  auto plan = attacks::law_attack_of(svc, {flight::AttackLaw::SetpointShift});
  if (!svc.require(plan, "bad attack params")) return false;
  if (!*plan) return true;
  auto window = std::make_shared<attacks::LawWindow>(**plan);
  node.set_attack_hook([&svc, window](Nanos) -> std::optional<flight::StateVec> {
    const auto tau = attacks::law_tau(*window, svc);
    if (!tau) return std::nullopt;
    return flight::setpoint_offset(window->attack().magnitude, *tau);
  });
  return true;
}

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
