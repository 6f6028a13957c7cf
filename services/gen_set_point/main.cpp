// rejuv_gen_set_point: the setpoint generator as a process (services/gen_set_point/include/rejuv/services/
// gen_set_point/setpoint_node.hpp). No command line: started by the kernel.
#include <string_view>

#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/gen_set_point/setpoint_node.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

// The mission state the kernel keeps (paper §III "Persistent data"; docs/design.md §7 "Cold restart") and the
// mission commander validated and wrote in MC, as persistent cells.
constexpr std::string_view kState = "mission_state";
constexpr std::string_view kUpload = "uploaded_mission";

// The generator's reactions to its inputs around the node: the kept mission state, the applied uploads and
// the published setpoint.
class Generator {
 public:
  Generator(sdk::Service& svc, services::SetpointNode& node, sdk::Publisher<rejuv_msg_Setpoint> setpoint)
      : svc_(svc), node_(node), setpoint_(setpoint) {}

  // After a cold restart the record says which mission is flown and where x_sp was, so the restarted
  // generator goes on from there instead of from waypoint 0. At the first boot the cell is empty.
  void resume_kept_mission() {
    auto kept = flight_io::read_mission_cell(svc_, kState);
    if (!kept) {
      svc_.log(sdk::LogLevel::Error, "the kept mission state is unusable: " + kept.error());
      return;
    }
    if (!*kept) return;
    if (auto ok = node_.restore(**kept, svc_.now()); !ok) {
      svc_.log(sdk::LogLevel::Error, "the kept mission state is unusable: " + ok.error().to_string());
    } else {
      svc_.logf(sdk::LogLevel::Info, "cold restart: continuing the kept mission (%zu waypoints) on segment %zu at %.3f",
                (**kept).mission.waypoints.size(), (**kept).cursor.segment, (**kept).cursor.tau);
    }
  }

  void on_mission(const rejuv_msg_MissionWaypoints& m) {
    if (auto ok = node_.on_mission(m); !ok) {
      svc_.log(sdk::LogLevel::Error, "refusing the mission: " + ok.error().to_string());
      return;
    }
    publish_changed();
  }

  void on_state(const rejuv_msg_VehicleStateEstimate& m) {
    if (auto ok = node_.on_state(m); !ok) return refuse_(ok.error());
    publish_changed();
  }

  void on_request(const rejuv_msg_SetpointUpdateRequest& m) {
    apply_upload();
    (void)node_.on_update_request(m);
    keep_state();
    publish_changed();
  }

  // After every input: publish a changed setpoint as soon as the mode grants it (the SEI).
  void publish_changed() {
    if (!setpoint_.allowed()) return;
    if (auto m = node_.take_changed()) {
      (void)setpoint_.publish(*m);
      if (m->mission_done != 0 && !announced_done_) {
        announced_done_ = true;
        svc_.log(sdk::LogLevel::Info, "mission done: the last waypoint is reached");
      }
    }
  }

 private:
  // Written only where the policy grants it (UPDATE: inside the secure execution interval).
  void keep_state() {
    const auto record = node_.record();
    if (!record) return;
    if (auto ok = flight_io::write_mission_cell(svc_, kState, *record); !ok) {
      svc_.log(sdk::LogLevel::Error, "keeping the mission state: " + ok.error());
    }
  }

  // A validated upload (commander wrote it to the cell in MC) takes effect at the setpoint update. Read and
  // checked again here, in the secure execution interval, by code restored from a clean image.
  void apply_upload() {
    auto pending = flight_io::read_mission_cell(svc_, kUpload);
    if (!pending) {
      svc_.log(sdk::LogLevel::Warn, "ignoring the uploaded mission: " + pending.error());
      return;
    }
    if (!*pending) return;
    auto applied = node_.apply_upload((**pending).mission, svc_.now());
    if (!applied) {
      svc_.log(sdk::LogLevel::Warn, "ignoring the uploaded mission: " + applied.error().to_string());
    } else if (*applied == services::SetpointNode::UploadOutcome::Applied) {
      svc_.logf(sdk::LogLevel::Info, "flying the uploaded mission of %zu waypoints from the current setpoint",
                (**pending).mission.waypoints.size());
    }
  }

  sdk::Service& svc_;
  services::SetpointNode& node_;
  sdk::Publisher<rejuv_msg_Setpoint> setpoint_;
  flight_io::FirstRefusalLog refuse_{svc_, "ignoring a message"};
  bool announced_done_ = false;
};

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  const flight_io::Params params = flight_io::params_of(svc);
  auto tracking = flight_io::tracking_params(params);
  if (!svc.require(tracking, "bad params")) return 1;
  auto design = flight_io::control_design(params);
  if (!svc.require(design, "bad params")) return 1;
  services::SetpointNode node(design->ellipsoid, *tracking);
  if (!services::arm_attack(svc, node)) return 1;  // the attack library (test builds only)

  auto setpoint = svc.advertise<rejuv_msg_Setpoint>("setpoint");
  if (!svc.require(setpoint, "setpoint")) return 1;
  Generator gen(svc, node, *setpoint);
  gen.resume_kept_mission();
  auto mission = svc.subscribe<rejuv_msg_MissionWaypoints>(
      "mission", [&](const rejuv_msg_MissionWaypoints& m) { gen.on_mission(m); });
  auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>(
      "vehicle_state", [&](const rejuv_msg_VehicleStateEstimate& m) { gen.on_state(m); });
  auto request = svc.subscribe<rejuv_msg_SetpointUpdateRequest>(
      "setpoint_update_request", [&](const rejuv_msg_SetpointUpdateRequest& m) { gen.on_request(m); });
  if (!svc.require_all("subscribe", mission, state, request)) return 1;
  // A restored setpoint goes out right after the clock starts, before the first estimate: the controllers
  // restarted with it must not steer for the take-off point meanwhile.
  auto boot = svc.after(Nanos{1}, [&] { gen.publish_changed(); });
  if (!svc.require(boot, "timer")) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve); }
