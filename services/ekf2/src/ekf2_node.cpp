#include "rejuv/services/ekf2/ekf2_node.hpp"

#include <utility>

namespace rejuv::services {

Ekf2Node::Ekf2Node(const flight::EkfParams& params, const flight::EkfState& initial, Nanos imu_period)
    : node_(params, initial, imu_period) {}

void Ekf2Node::flush_held() {
  (void)node_.on_samples(held_);  // no gyro sample: fuses only, x̂ is published with the next tick
  held_ = {};
}

Result<void, flight_io::InputFailure> Ekf2Node::on_mag(const rejuv_msg_SensorMag& message) {
  auto s = flight_io::mag_sample(message);
  if (!s) return fail(std::move(s.error()));
  if (held_.mag) flush_held();
  held_.mag = *s;
  return {};
}

Result<void, flight_io::InputFailure> Ekf2Node::on_baro(const rejuv_msg_SensorBaro& message) {
  auto s = flight_io::baro_sample(message);
  if (!s) return fail(std::move(s.error()));
  if (held_.baro) flush_held();
  held_.baro = *s;
  return {};
}

Result<void, flight_io::InputFailure> Ekf2Node::on_gps(const rejuv_msg_SensorGps& message) {
  auto s = flight_io::gps_sample(message);
  if (!s) return fail(std::move(s.error()));
  if (held_.gps) flush_held();
  held_.gps = *s;
  return {};
}

void Ekf2Node::on_rollback(const flight::EkfRearm& rearm) {
  held_ = {};
  node_.on_rollback(rearm);
}

Result<rejuv_msg_VehicleStateEstimate, flight_io::InputFailure> Ekf2Node::on_combined(
    const rejuv_msg_SensorCombined& message) {
  auto tick = flight_io::imu_tick(message);
  if (!tick) return fail(std::move(tick.error()));
  plant::SensorSamples samples = held_;
  samples.gyro = tick->gyro;
  samples.accel = tick->accel;
  held_ = {};
  const flight::EkfCounters before = node_.ekf().counters();
  const bool integrated = node_.on_samples(samples);
  REJUV_ASSERT(integrated, "a sample set with a gyro sample is integrated");
  integrated_ = true;
  return flight_io::vehicle_state_message(node_, tick->gyro.t, flags(before));
}

std::uint32_t Ekf2Node::flags(const flight::EkfCounters& before) const {
  const flight::EkfCounters& now = node_.ekf().counters();
  std::uint32_t f = 0;
  if (integrated_) f |= flight_io::kStateAttitudeValid;
  // Position: the filter starts from the known take-off point; it is valid once GPS has confirmed it.
  if (now.gps_fused + now.gps_resets > 0) f |= flight_io::kStatePositionValid;
  if (now.gps_rejected != before.gps_rejected || now.baro_rejected != before.baro_rejected ||
      now.mag_rejected != before.mag_rejected) {
    f |= flight_io::kStateInnovationRejected;
  }
  return f;
}

}  // namespace rejuv::services
