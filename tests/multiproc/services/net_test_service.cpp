// The `vehicle` of the network gate's multi-process test (tests/multiproc/graphs/net.policy.pbtxt): stands in
// for the flight stack next to the real ext_link. Every 20 ms it publishes a vehicle_state and a setpoint
// (so that ext_link has telemetry to send); it reads mission_upload (as commander would); on every
// mode_command (injected by the test as the kernel) it requests that mode through its Mode cap and then, as
// a compromised service would, tries to send on the network without asking the SDK whether it may (a
// NetSend outside MC must be denied by the kernel).
#include <chrono>
#include <string>

#include "rejuv/sdk/service.hpp"
#include "rejuv/sdk/testing.hpp"

int main() {
  using namespace rejuv;
  auto connected = sdk::Service::connect();
  if (!connected) return sdk::report_connect_failure(connected.error());
  sdk::Service& svc = **connected;

  auto state = svc.advertise<rejuv_msg_VehicleStateEstimate>("vehicle_state");
  if (!svc.require(state, "vehicle_state")) return 3;
  auto setpoint = svc.advertise<rejuv_msg_Setpoint>("setpoint");
  if (!svc.require(setpoint, "setpoint")) return 3;
  auto uploads = svc.subscribe<rejuv_msg_MissionWaypoints>("mission_upload", [&](const rejuv_msg_MissionWaypoints& m) {
    svc.logf(sdk::LogLevel::Info, "mission upload of %u waypoints", m.count);
  });
  if (!svc.require(uploads, "mission_upload")) return 3;
  auto net = svc.cap("ext_net");
  if (!svc.require(net, "ext_net")) return 3;
  const Slot net_slot = (*net)->slot;
  // mode_command: a SensorBaro record whose altitude_m is the SrMode index to request.
  auto commands = svc.subscribe<rejuv_msg_SensorBaro>("mode_command", [&](const rejuv_msg_SensorBaro& m) {
    const auto mode = static_cast<std::uint64_t>(m.altitude_m);
    if (auto ok = rejuv::sdk::testing::invoke(svc, "sr_mode_control", cap::Operation::ModeRequest, mode); !ok) {
      svc.log(sdk::LogLevel::Error, "mode request: " + ok.error().to_string());
      return;
    }
    const std::string rogue = "rogue datagram";
    auto sent = rejuv::sdk::testing::invoke_slot(svc, net_slot, cap::Operation::NetSend, 0, 0, std::as_bytes(std::span(rogue)));
    svc.logf(sdk::LogLevel::Info, "NetSend in mode %u: %s", static_cast<unsigned>(mode),
             sent ? "sent" : sent.error().to_string().c_str());
  });
  if (!svc.require(commands, "mode_command")) return 3;

  auto tick = svc.every(std::chrono::milliseconds{20}, [&] {
    const double t = to_seconds(svc.now()).count();
    rejuv_msg_VehicleStateEstimate x{};
    x.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
    x.p_N_m[0] = t;
    x.p_N_m[2] = -3;
    x.q_NB[0] = 1;
    (void)state->publish(x);
    rejuv_msg_Setpoint sp{};
    sp.timestamp_ns = x.timestamp_ns;
    sp.p_N_m[0] = 1;
    sp.p_N_m[2] = -3;
    sp.waypoint_index = 1;
    (void)setpoint->publish(sp);
  });
  if (!svc.require(tick, "timer")) return 3;
  return svc.run();
}
