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

}  // namespace rejuv::services
