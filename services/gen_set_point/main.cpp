// rejuv_gen_set_point: the setpoint generator as a process (services/gen_set_point/include/rejuv/services/
// gen_set_point/setpoint_node.hpp). No command line: started by the kernel.
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/gen_set_point/setpoint_node.hpp"

int main() {
  using namespace rejuv;
  auto connected = sdk::Service::connect();
  if (!connected) return sdk::report_connect_failure(connected.error());
  sdk::Service& svc = **connected;

  const flight_io::Params params = flight_io::params_of(svc);
  auto tracking = flight_io::tracking_params(params);
  if (!svc.require(tracking, "bad params")) return 1;
  auto design = flight_io::control_design(params);
  if (!svc.require(design, "bad params")) return 1;
  services::SetpointNode node(design->ellipsoid, *tracking);

  auto setpoint = svc.advertise<rejuv_msg_Setpoint>("setpoint");
  if (!svc.require(setpoint, "setpoint")) return 1;
  bool announced_done = false;
  // After every input: publish a changed setpoint as soon as the mode grants it (the SEI).
  const auto publish_changed = [&] {
    if (!setpoint->allowed()) return;
    if (auto m = node.take_changed()) {
      (void)setpoint->publish(*m);
      if (m->mission_done != 0 && !announced_done) {
        announced_done = true;
        svc.log(sdk::LogLevel::Info, "mission done: the last waypoint is reached");
      }
    }
  };
  flight_io::FirstRefusalLog refuse(svc, "ignoring a message");
  const auto on_mission = [&](const rejuv_msg_MissionWaypoints& m) {
    if (auto ok = node.on_mission(m); !ok) {
      svc.log(sdk::LogLevel::Error, "refusing the mission: " + ok.error().to_string());
      return;
    }
    publish_changed();
  };
  const auto on_state = [&](const rejuv_msg_VehicleStateEstimate& m) {
    if (auto ok = node.on_state(m); !ok) return refuse(ok.error());
    publish_changed();
  };
  const auto on_request = [&](const rejuv_msg_SetpointUpdateRequest& m) {
    (void)node.on_update_request(m);
    publish_changed();
  };
  auto mission = svc.subscribe<rejuv_msg_MissionWaypoints>("mission", on_mission);
  auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state", on_state);
  auto request = svc.subscribe<rejuv_msg_SetpointUpdateRequest>("setpoint_update_request", on_request);
  if (!svc.require_all("subscribe", mission, state, request)) return 1;
  return svc.run();
}
