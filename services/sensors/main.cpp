// rejuv_sensors: raw IMU topics → sensor_combined (services/sensors/include/rejuv/services/sensors/
// imu_combiner.hpp). No command line: started by the kernel, which passes everything through the channel.
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/sensors/imu_combiner.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  auto combined = svc.advertise<rejuv_msg_SensorCombined>("sensor_combined");
  if (!svc.require(combined, "sensor_combined")) return 1;
  flight_io::FirstRefusalLog refuse(svc, "dropping a sample");
  services::ImuCombiner combiner(flight_io::imu_period(), [&](const rejuv_msg_SensorCombined& m) {
    (void)combined->publish(m);  // granted in every mode; a refusal is the kernel's to count
  });

  if (!services::arm_attack(svc, combiner)) return 1;  // the attack library (test builds only)
  auto gyro = svc.subscribe<rejuv_msg_SensorGyro>("sensor_gyro", [&](const rejuv_msg_SensorGyro& m) {
    if (auto ok = combiner.on_gyro(m); !ok) refuse(ok.error());
  });
  auto accel = svc.subscribe<rejuv_msg_SensorAccel>("sensor_accel", [&](const rejuv_msg_SensorAccel& m) {
    if (auto ok = combiner.on_accel(m); !ok) refuse(ok.error());
  });
  // sensor_mag, sensor_baro and sensor_gps are granted to this service too (PX4's sensors hub reads them
  // all), but ekf2 reads them directly: subscribing here would only cost deliveries.
  if (!svc.require_all("subscribe", gyro, accel)) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve); }
