// rejuv_safety_control: the safety controller as a process (services/safety_control/include/rejuv/services/
// safety_control/safety_control.hpp). No command line: started by the kernel.
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/safety_control/safety_control.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  auto start = flight_io::control_start(flight_io::params_of(svc));
  if (!svc.require(start, "bad params")) return 1;
  services::SafetyControl control(start->design, start->x_sp);

  auto controls = svc.advertise<rejuv_msg_ActuatorControls>("actuator_controls");
  if (!svc.require(controls, "actuator_controls")) return 1;
  flight_io::FirstRefusalLog refuse(svc, "ignoring a message");
  auto setpoint = svc.subscribe<rejuv_msg_Setpoint>("setpoint", [&](const rejuv_msg_Setpoint& m) {
    if (auto ok = control.on_setpoint(m); !ok) refuse(ok.error());
  });
  bool publishing = false;
  const auto on_state = [&](const rejuv_msg_VehicleStateEstimate& m) {
    auto u = control.on_state(m, svc.epoch());
    if (!u) return refuse(u.error());
    // Warm in every mode; the controls reach the driver only where the policy grants it (the SEI).
    const bool allowed = controls->allowed();
    if (allowed != publishing) {
      publishing = allowed;
      svc.logf(sdk::LogLevel::Debug, "%s publishing (mode %s)", allowed ? "start" : "stop",
               std::string(to_string(svc.mode())).c_str());
    }
    if (*u && allowed) {
      (void)controls->publish(**u);
    }
  };
  auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state", on_state);
  if (!svc.require_all("subscribe", setpoint, state)) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve); }
