#include "rejuv/flight/estimator_node.hpp"

namespace rejuv::flight {

EstimatorNode::EstimatorNode(const EkfParams& params, const EkfState& initial, Nanos imu_period)
    : ekf_(params, initial), imu_period_(imu_period), last_f_B_m_s2_(0.0, 0.0, -params.gravity_m_s2) {
  refresh_estimate();
}

bool EstimatorNode::on_samples(const plant::SensorSamples& samples) {
  if (!samples.gyro && !samples.accel && !samples.gps && !samples.baro && !samples.mag) return false;
  if (samples.accel) last_f_B_m_s2_ = samples.accel->f_B_m_s2;
  bool integrated = false;
  if (samples.gyro) {
    // The IMU's own interval, unless the gap is implausible (first sample; or a rollback restored an old
    // timestamp, §V: time goes on while the image is old): then one nominal period.
    Nanos dt = imu_period_;
    if (last_gyro_t_) {
      const Nanos gap = samples.gyro->t - *last_gyro_t_;
      if (gap > Nanos{0} && gap <= 2 * imu_period_) dt = gap;
    }
    last_gyro_t_ = samples.gyro->t;
    last_omega_raw_B_rad_s_ = samples.gyro->omega_B_rad_s;
    ekf_.predict(samples.gyro->omega_B_rad_s, last_f_B_m_s2_, to_seconds(dt));
    (void)ekf_.fuse_drag(last_f_B_m_s2_, dt);
    integrated = true;
  }
  if (samples.gps) (void)ekf_.fuse_gps(*samples.gps);
  if (samples.baro) (void)ekf_.fuse_baro(*samples.baro);
  if (samples.mag) (void)ekf_.fuse_mag(*samples.mag);
  refresh_estimate();
  return integrated;
}

void EstimatorNode::on_rollback(const EkfRearm& rearm) {
  if (!rearm.enabled) return;  // the restored filter goes on as it was at the checkpoint
  // The filter keeps its own parameters for everything but the initial covariance it is rebuilt with.
  EkfParams params = ekf_.params();
  params.initial_position_std_m = rearm.position_std_m;
  params.initial_velocity_std_m_s = rearm.velocity_std_m_s;
  params.initial_attitude_std_rad = rearm.attitude_std_rad;
  params.initial_gyro_bias_std_rad_s = rearm.gyro_bias_std_rad_s;
  params.initial_accel_bias_std_m_s2 = rearm.accel_bias_std_m_s2;
  ekf_ = Ekf(params, ekf_.state());
  refresh_estimate();
}

void EstimatorNode::refresh_estimate() {
  const EkfState& s = ekf_.state();
  x_hat_ = make_state(s.p_N_m, s.v_N_m_s, euler_from_quaternion(s.q_NB),
                      ekf_.omega_B_corrected(last_omega_raw_B_rad_s_));
}

}  // namespace rejuv::flight
