// rejuv_lqr_control: the mission controller as a process (services/lqr_control/include/rejuv/services/
// lqr_control/mission_control.hpp). No command line: started by the kernel.
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/lqr_control/mission_control.hpp"
#if defined(REJUV_ATTACK_HOOKS)
#include <optional>
#include <string>
#include <string_view>

#include "rejuv/services/lqr_control/worst_case_attack.hpp"
#include "rejuv/services/service_main.hpp"
#endif

namespace {

using namespace rejuv;

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  const flight_io::Params params = flight_io::params_of(svc);
  auto start = flight_io::control_start(params);
  if (!svc.require(start, "bad params")) return 1;
  services::MissionControl control(start->design, start->x_sp);
  if (!services::arm_attack(svc, control)) return 1;  // the attack library (test builds only)

#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK (test builds only) ====: the launch plan's worst-case control attack (§VI-D), when an
  // attack of kind WORST_CASE_CONTROL names this service and attacks are on (attack.* boot params).
  auto plan = services::worst_case_attack_plan(
      params, [&svc](std::string_view name) { return std::string(svc.text_param(name, "")); });
  if (!svc.require(plan, "bad attack params")) return 1;
  std::optional<services::WorstCaseAttack> attack;
  if (*plan) {
    attack.emplace(**plan, start->design);
    svc.logf(sdk::LogLevel::Warn, "attack hook armed: worst-case control from t = %g s, %s",
             (*plan)->start.count(),
             (*plan)->max_windows == 0 ? "every MC window"
                                       : (std::to_string((*plan)->max_windows) + " MC window(s)").c_str());
    control.set_attack_hook(
        [&](const flight::StateVec& x_hat, const flight::StateVec& x_sp, const flight::InputVec&) {
          const std::uint64_t before = attack->windows_attacked();
          auto forged = attack->on_control(svc.now(), svc.mode(), svc.epoch(), x_hat, x_sp);
          if (attack->windows_attacked() != before) {
            svc.logf(sdk::LogLevel::Debug, "attacking the MC window of epoch %u", svc.epoch().value());
          }
          return forged;
        });
  }
#endif

  auto controls = svc.advertise<rejuv_msg_ActuatorControls>("actuator_controls");
  if (!svc.require(controls, "actuator_controls")) return 1;
  flight_io::FirstRefusalLog refuse(svc, "ignoring a message");
  auto setpoint = svc.subscribe<rejuv_msg_Setpoint>("setpoint", [&](const rejuv_msg_Setpoint& m) {
    if (auto ok = control.on_setpoint(m); !ok) refuse(ok.error());
  });
  const auto on_state = [&](const rejuv_msg_VehicleStateEstimate& m) {
    auto u = control.on_state(m, svc.epoch());
    if (!u) return refuse(u.error());
    // Tracking runs in every mode; the controls reach the driver only where the policy grants it (MC).
    if (*u && controls->allowed()) {
      (void)controls->publish(**u);
    }
  };
  auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state", on_state);
  if (!svc.require_all("subscribe", setpoint, state)) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve); }
