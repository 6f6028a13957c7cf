#include "rejuv/services/sensors/imu_combiner.hpp"

#include <utility>

namespace rejuv::services {

ImuCombiner::ImuCombiner(Nanos imu_period, Sink emit) : imu_period_(imu_period), sink_(std::move(emit)) {
  REJUV_ASSERT(imu_period_ > Nanos{0}, "the IMU period is positive");
}

Result<void, flight_io::InputFailure> ImuCombiner::on_gyro(const rejuv_msg_SensorGyro& message) {
  auto gyro = flight_io::gyro_sample(message);
  if (!gyro) return fail(std::move(gyro.error()));
  if (pending_gyro_) {
    // The previous tick's accelerometer sample never came: that tick goes with the held one.
    emit(*pending_gyro_);
    pending_gyro_.reset();
  }
  if (accel_ && accel_->t == gyro->t) {
    emit(*gyro);  // the accelerometer sample of this tick came first
  } else {
    pending_gyro_ = *gyro;
  }
  return {};
}

Result<void, flight_io::InputFailure> ImuCombiner::on_accel(const rejuv_msg_SensorAccel& message) {
  auto accel = flight_io::accel_sample(message);
  if (!accel) return fail(std::move(accel.error()));
  if (pending_gyro_ && pending_gyro_->t < accel->t) {
    // A newer tick's sample: the waiting gyro sample's own never came, it goes with the held one.
    emit(*pending_gyro_);
    pending_gyro_.reset();
  }
  accel_ = *accel;
  if (pending_gyro_ && pending_gyro_->t == accel->t) {
    emit(*pending_gyro_);
    pending_gyro_.reset();
  }
  return {};
}

Seconds ImuCombiner::interval(Nanos now, std::optional<Nanos>& last) const {
  // flight::EstimatorNode's rule: the sensor's own interval unless implausible, then one nominal period.
  Nanos dt = imu_period_;
  if (last) {
    const Nanos gap = now - *last;
    if (gap > Nanos{0} && gap <= 2 * imu_period_) dt = gap;
  }
  last = now;
  return to_seconds(dt);
}

void ImuCombiner::emit(const plant::GyroSample& gyro) {
  // Before the first accelerometer sample: level hover, as the estimator node assumes at start.
  const plant::AccelSample accel =
      accel_ ? *accel_
             : plant::AccelSample{.t = gyro.t,
                                  .f_B_m_s2 = Eigen::Vector3d(0, 0, -flight_io::ekf_params().gravity_m_s2)};
  const Seconds gyro_dt = interval(gyro.t, last_gyro_t_);
  const Seconds accel_dt = accel_ ? interval(accel.t, last_accel_t_) : to_seconds(imu_period_);
  ++published_;
  rejuv_msg_SensorCombined out = flight_io::combined_message(gyro, accel, gyro_dt, accel_dt);
#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK POINT ====
  if (attack_hook_) attack_hook_(out);
#endif
  if (sink_) sink_(out);
}

}  // namespace rejuv::services
