// rejuv_commander: publishes the launch graph's mission and validates uploads (services/commander/include/
// rejuv/services/commander/commander.hpp). No command line: started by the kernel.
#include <chrono>

#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/commander/commander.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  auto commander = services::Commander::from_params(flight_io::params_of(svc));
  if (!svc.require(commander, "refusing the mission")) return 1;
  if (commander->mission().from_defaults) {
    svc.log(sdk::LogLevel::Warn, "no mission.count param: flying the simulation's default mission");
  }
  auto mission = svc.advertise<rejuv_msg_MissionWaypoints>("mission");
  if (!svc.require(mission, "mission")) return 1;
  SrMode mode = svc.mode();
  auto modes = svc.subscribe<rejuv_msg_SrMode>("sr_mode", [&](const rejuv_msg_SrMode& m) {
    if (auto decoded = flight_io::mode_from_message(m)) mode = *decoded;
  });
  auto uploads =
      svc.subscribe<rejuv_msg_MissionWaypoints>("mission_upload", [&](const rejuv_msg_MissionWaypoints& m) {
        // Validated, then kept in the kernel's cell: the rollback that ends this MC window erases everything
        // else this process learns now. gen_set_point checks it again and applies it in UPDATE.
        auto checked = commander->validate_upload(m, mode);
        if (!checked) {
          svc.log(sdk::LogLevel::Warn, "mission upload refused: " + checked.error().to_string());
          return;
        }
        auto kept = flight_io::write_mission_cell(svc, "uploaded_mission",
                                                  flight_io::MissionRecord{.mission = *checked, .cursor = {}, .done = false});
        if (!kept || !*kept) {
          svc.log(sdk::LogLevel::Warn, "mission upload not kept: " + (kept ? std::string("no uploaded_mission cell in this mode") : kept.error()));
          return;
        }
        svc.logf(sdk::LogLevel::Info, "mission upload of %zu waypoints accepted: flown from the next setpoint update",
                 checked->waypoints.size());
      });
  if (!svc.require_all("subscribe", modes, uploads)) return 1;
  // Right after the start of the clock (every service has subscribed by then: the kernel starts it only
  // when all are Ready), so gen_set_point has the mission before the first estimate needs it.
  auto start = svc.after(Nanos{1}, [&] {
    if (auto ok = mission->publish(commander->mission_message(svc.now())); !ok) {
      svc.log(sdk::LogLevel::Error, "publishing the mission: " + ok.error().to_string());
    }
  });
  if (!svc.require(start, "timer")) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve, services::AttackHooks::Install); }
