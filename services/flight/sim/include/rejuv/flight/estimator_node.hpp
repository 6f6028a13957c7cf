// The `ekf2` node of the model-level simulation: feeds sensor samples to the EKF and forms the 12-state
// estimate x̂ the controllers and the SR checks use (§IV-A: "only the state estimation x̂ is available to make
// decisions"). A copyable value, part of the software image that a checkpoint saves and a rollback restores.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string_view>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/flight/ekf.hpp"
#include "rejuv/flight/hover_model.hpp"
#include "rejuv/plant/sensors.hpp"

namespace rejuv::flight {

// The uncertainty (1σ) the filter re-arms on a rollback (see EstimatorNode::on_rollback).
// The launch file's sr.ekf_rearm (idl/launch.proto EstimatorRearm); `enabled` false: no re-arm, the restored
// filter keeps its covariance (the paper's estimator).
struct EkfRearm {
  // The defaults are the graph-wide keys' (rejuv/core/graph_values.hpp).
  bool enabled = graph_values::kRearmEnabled.fallback;
  double position_std_m = graph_values::kRearmPositionStd.fallback;
  double velocity_std_m_s = graph_values::kRearmVelocityStd.fallback;
  double attitude_std_rad = graph_values::kRearmAttitudeStd.fallback;
  double gyro_bias_std_rad_s = graph_values::kRearmGyroBiasStd.fallback;
  double accel_bias_std_m_s2 = graph_values::kRearmAccelBiasStd.fallback;

  // Its 1σ fields by their name in the launch file (EstimatorRearm) and in ekf2's boot params
  // (sr.ekf_rearm.<name>): the one place the names meet the members.
  struct StdField {
    std::string_view name;
    double EkfRearm::*member;
  };
  static constexpr std::array<StdField, 5> kStdFields{{
      {"position_std_m", &EkfRearm::position_std_m},
      {"velocity_std_m_s", &EkfRearm::velocity_std_m_s},
      {"attitude_std_rad", &EkfRearm::attitude_std_rad},
      {"gyro_bias_std_rad_s", &EkfRearm::gyro_bias_std_rad_s},
      {"accel_bias_std_m_s2", &EkfRearm::accel_bias_std_m_s2},
  }};
};

class EstimatorNode {
 public:
  // imu_period: the IMU's sample interval, used as the integration step whenever the time since the previous
  // gyro sample is implausible (the first sample, or the first one after a rollback restored an old timestamp).
  EstimatorNode(const EkfParams& params, const EkfState& initial, Nanos imu_period);

  // Consumes the samples of one physics step. Returns true when a gyro sample was integrated, i.e. a new x̂
  // is available (the controllers run on that event, at the IMU rate, like PX4's rate loop).
  bool on_samples(const plant::SensorSamples& samples);

  // The node's RollbackSignal handler (docs/design.md §7: services may ask for it). The restored estimate is
  // T_MC + T_RB old while the vehicle kept moving, yet its covariance still says "converged": the first GPS
  // samples would fail their gates and a tilt error would persist for seconds. So the node keeps the restored
  // state but re-arms the filter's uncertainty, and the measurements pull it back within T_est (§IV-A).
  void on_rollback(const EkfRearm& rearm);

  // x̂ = [p̂_N, v̂_N, euler(q̂_NB), ω_B corrected by the estimated gyro bias].
  [[nodiscard]] const StateVec& estimate() const { return x_hat_; }
  [[nodiscard]] const Ekf& ekf() const { return ekf_; }

 private:
  void refresh_estimate();

  Ekf ekf_;
  Nanos imu_period_;
  std::optional<Nanos> last_gyro_t_;
  Eigen::Vector3d last_f_B_m_s2_;
  Eigen::Vector3d last_omega_raw_B_rad_s_ = Eigen::Vector3d::Zero();
  StateVec x_hat_ = StateVec::Zero();
};

}  // namespace rejuv::flight
