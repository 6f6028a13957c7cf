// The start-up of the project's flight services: sdk::run_service, plus, in a test build
// (REJUV_ATTACK_HOOKS), the launch plan's runtime attack hooks for the services that carry them
// (services/attacks; launch::attack_hooks_of says which). A service's main() is then
//
//   int main() {
//     return rejuv::services::run_service([](rejuv::sdk::Service& svc) { ...; return svc.run(); },
//                                         rejuv::services::AttackHooks::Install);
//   }
#pragma once

#include <cstdint>

#include "rejuv/sdk/run.hpp"

namespace rejuv::services {

// Whether this service installs the runtime attack hooks before its set-up (test builds only: in a build
// without REJUV_ATTACK_HOOKS, Install does nothing).
enum class AttackHooks : std::uint8_t { None, Install };

// sdk::run_service(body); with Install in a test build, attacks::install(svc) first (a bad plan: exit 1).
[[nodiscard]] int run_service(const sdk::ServiceMain& body, AttackHooks hooks = AttackHooks::None);

// The attack library's attack on a service's node (docs/control.md "Attack library"), armed at boot. A node
// type that carries an attack hook has `arm_library_attack(sdk::Service&, Node&)` declared beside it; a test
// build (REJUV_ATTACK_HOOKS) defines it in the service's attack .cpp and calls it here. Any other build holds
// no attack code, and arming does nothing. False (the error logged) on bad attack params: the service refuses
// to boot.
template <typename Node>
[[nodiscard]] bool arm_attack(sdk::Service& svc, Node& node) {
#if defined(REJUV_ATTACK_HOOKS)
  return arm_library_attack(svc, node);
#else
  (void)svc;
  (void)node;
  return true;
#endif
}

}  // namespace rejuv::services
