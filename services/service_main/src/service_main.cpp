#include "rejuv/services/service_main.hpp"

#if defined(REJUV_ATTACK_HOOKS)
#include "rejuv/attacks/hooks.hpp"
#endif

namespace rejuv::services {

int run_service(const sdk::ServiceMain& body, AttackHooks hooks) {
  return sdk::run_service([&](sdk::Service& svc) {
#if defined(REJUV_ATTACK_HOOKS)
    // ==== ATTACK HOOKS (test builds only) ====: the launch plan's runtime attacks that name this service
    // (services/attacks; wiped by rollback like any corruption — what outlives an image, the kernel removes).
    // They live as long as the event loop: until body returns.
    if (hooks == AttackHooks::Install) {
      auto attack_hooks = attacks::install(svc);
      if (!svc.require(attack_hooks, "bad attack params")) return 1;
      return body(svc);
    }
#else
    (void)hooks;
#endif
    return body(svc);
  });
}

}  // namespace rejuv::services
