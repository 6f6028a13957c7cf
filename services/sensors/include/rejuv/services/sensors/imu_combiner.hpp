// The `sensors` service (PX4 `sensors` module, docs/design.md §2): raw IMU topics from the plant → sensor_combined,
// one message per IMU tick with the gyro and accelerometer samples of that tick.
//
// Topics: in sensor_gyro, sensor_accel (250 Hz, bridged in from the plant over DDS); out sensor_combined
// (250 Hz, on the tick's second sample). sensor_mag, sensor_baro and sensor_gps go to ekf2 directly (launch
// graph); this service does not subscribe them (the graph grants them, nothing here needs them). Params:
// none.
//
// Pairing follows what the simulation's estimator node does with the samples of one physics step
// (flight::EstimatorNode::on_samples): a tick's gyro sample goes with the accelerometer sample of the same
// time stamp; a gyro sample whose accelerometer sample never comes goes with the last accelerometer sample
// (the estimator node holds it the same way). Arrival order within a tick does not matter.
// gyro_dt / accel_dt: the interval since the previous sample of that sensor, or one nominal IMU period when
// that gap is implausible (≤ 0 or > 2 periods: the first sample, or a rollback that restored an old stamp) —
// the rule of EstimatorNode.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>

#include "rejuv/core/time.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::sdk {
class Service;
}  // namespace rejuv::sdk

namespace rejuv::services {

class ImuCombiner {
 public:
  using Sink = std::function<void(const rejuv_msg_SensorCombined&)>;

  // `imu_period`: the nominal IMU interval (flight_io::imu_period()). `emit` receives each combined tick.
  ImuCombiner(Nanos imu_period, Sink emit);

  // Non-finite samples are refused (nothing changes): the IMU feeds the estimator every tick.
  Result<void, flight_io::InputFailure> on_gyro(const rejuv_msg_SensorGyro& message);
  Result<void, flight_io::InputFailure> on_accel(const rejuv_msg_SensorAccel& message);

  [[nodiscard]] std::uint64_t published() const { return published_; }

#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK (test builds only; arm_library_attack) ====
  // Sees every combined tick on its way out and may change it (a compromised sensors service).
  using CombinedHook = std::function<void(rejuv_msg_SensorCombined&)>;
  void set_attack_hook(CombinedHook hook) { attack_hook_ = std::move(hook); }
#endif

 private:
  void emit(const plant::GyroSample& gyro);
  [[nodiscard]] Seconds interval(Nanos now, std::optional<Nanos>& last) const;

  Nanos imu_period_;
  Sink sink_;
  std::optional<plant::GyroSample> pending_gyro_;  // waiting for the accel sample of its tick
  std::optional<plant::AccelSample> accel_;        // the latest accelerometer sample
  std::optional<Nanos> last_gyro_t_;               // of the last published tick
  std::optional<Nanos> last_accel_t_;
  std::uint64_t published_ = 0;
#if defined(REJUV_ATTACK_HOOKS)
  CombinedHook attack_hook_;
#endif
};

// The attack library on sensors (docs/control.md "Attack library", flight/attack_library.hpp): SENSOR_BIAS, a
// compromised sensors service that adds a gyro bias to every combined tick in attacked MC windows; ekf2
// integrates it. The bias and the window live in this process's memory (the hook of ImuCombiner): the rollback
// erases them (and ekf2's rollback what it integrated). Armed at boot by services::arm_attack
// (service_main.hpp), which calls this in a test build; defined in bias_attack.cpp.
[[nodiscard]] bool arm_library_attack(sdk::Service& svc, ImuCombiner& combiner);
// SLOW_REPLAY and LYING_REPLAY (replay_attack.cpp): a sensors service that acts only on the samples the kernel
// replays after a rollback (docs/control.md §6.3). Called by arm_library_attack when the plan names no
// SENSOR_BIAS. False (the error logged) on bad params.
[[nodiscard]] bool arm_replay_attack(sdk::Service& svc, ImuCombiner& combiner);

}  // namespace rejuv::services
