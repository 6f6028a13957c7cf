// rejuv_ekf2: the state estimator as a process (services/ekf2/include/rejuv/services/ekf2/ekf2_node.hpp).
// No command line: started by the kernel, which passes everything through the channel.
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/ekf2/ekf2_node.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  auto mission = flight_io::mission_params(flight_io::params_of(svc));
  if (!svc.require(mission, "bad params")) return 1;
  // At the first boot the vehicle rests at its take-off point, the mission's first waypoint. After a cold
  // restart (the kernel counts them in boot.cold_restarts) it is wherever the mission had taken it: the filter
  // starts from the first GPS fix instead (docs/design.md §7 "Cold restart"), level, with the mission's first heading
  // (the magnetometer corrects it).
  const bool cold_restart = svc.param("boot.cold_restarts", 0.0) > 0.0;
  const flight::EkfState take_off = flight_io::ekf_initial_state(*mission);
  services::Ekf2Node ekf2 =
      cold_restart ? services::Ekf2Node::from_first_fix(flight_io::ekf_params(), take_off.q_NB, flight_io::imu_period())
                   : services::Ekf2Node(flight_io::ekf_params(), take_off, flight_io::imu_period());
  if (cold_restart) svc.log(sdk::LogLevel::Info, "cold restart: the estimate starts from the first GPS fix");
  if (!services::arm_attack(svc, ekf2)) return 1;  // the attack library (test builds only)

  auto state = svc.advertise<rejuv_msg_VehicleStateEstimate>("vehicle_state");
  if (!svc.require(state, "vehicle_state")) return 1;
  flight_io::FirstRefusalLog refuse(svc, "dropping a sample");
  auto combined =
      svc.subscribe<rejuv_msg_SensorCombined>("sensor_combined", [&](const rejuv_msg_SensorCombined& m) {
        auto x_hat = ekf2.on_combined(m);
        if (!x_hat) return refuse(x_hat.error());
        if (*x_hat) (void)state->publish(**x_hat);  // granted in every mode
      });
  auto mag = svc.subscribe<rejuv_msg_SensorMag>("sensor_mag", [&](const rejuv_msg_SensorMag& m) {
    if (auto ok = ekf2.on_mag(m); !ok) refuse(ok.error());
  });
  auto baro = svc.subscribe<rejuv_msg_SensorBaro>("sensor_baro", [&](const rejuv_msg_SensorBaro& m) {
    if (auto ok = ekf2.on_baro(m); !ok) refuse(ok.error());
  });
  auto gps = svc.subscribe<rejuv_msg_SensorGps>("sensor_gps", [&](const rejuv_msg_SensorGps& m) {
    if (auto ok = ekf2.on_gps(m); !ok) refuse(ok.error());
  });
  // The simulation re-arms the estimator on every rollback (flight/sim: RollbackSignal to ekf2 and
  // checkpoint_p). Subscribed when the policy grants rollback_signal to ekf2.
  const auto rearm_params = flight_io::ekf_rearm(flight_io::params_of(svc));
  if (!svc.require(rearm_params, "bad params")) return 1;
  const flight::EkfRearm rearm = *rearm_params;
  if (svc.cap("rollback_signal")) {
    auto rollback = svc.subscribe<rejuv_msg_RollbackSignal>(
        "rollback_signal", [&](const rejuv_msg_RollbackSignal& m) {
          const std::uint32_t discarded = ekf2.catch_up_discarded();
          ekf2.on_rollback_signal(m, rearm);  // with the catch-up: its state (docs/control.md §6.3)
          if (ekf2.catch_up_discarded() != discarded) {
            svc.logf(sdk::LogLevel::Info, "rollback to g %llu (epoch %u): the replayed estimate failed its GPS gate; "
                     "discarded, the restored estimator re-armed", static_cast<unsigned long long>(m.generation), m.epoch);
          }
          svc.logf(sdk::LogLevel::Debug, "rollback to g %llu (epoch %u), catch-up %d: %s",
                   static_cast<unsigned long long>(m.generation), m.epoch, static_cast<int>(m.catch_up),
                   rearm.enabled ? "estimator re-armed" : "held samples dropped, covariance kept (sr.ekf_rearm off)");
        });
    if (!svc.require(rollback, "subscribe")) return 1;
  } else {
    svc.log(sdk::LogLevel::Warn,
            "the policy grants no rollback_signal to ekf2: the estimator is not re-armed after a rollback "
            "(the simulation re-arms it)");
  }
  if (!svc.require_all("subscribe", combined, mag, baro, gps)) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve, services::AttackHooks::Install); }
