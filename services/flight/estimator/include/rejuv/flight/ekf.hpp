// The state estimator of the flight stack (docs/design.md §9, the `ekf2` of §III-A): an error-state extended Kalman
// filter that integrates the IMU and fuses GPS position + velocity, barometric altitude, magnetic heading and
// the multirotor drag constraint on the horizontal specific force; the barometer's bias is a state, so that GPS
// height anchors the altitude over hours while the barometer smooths it.
// Frames: N = local NED, B = body FRD; q_NB rotates B-frame vectors into N.
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rejuv/core/time.hpp"
#include "rejuv/plant/sensor_samples.hpp"

namespace rejuv::flight {

// The nominal (total) state: the best estimate of the vehicle and of the IMU biases.
struct EkfState {
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();    // position of B in N, m
  Eigen::Vector3d v_N_m_s = Eigen::Vector3d::Zero();  // velocity of B in N, m/s
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();  // in B
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();  // in B
  double baro_bias_m = 0;  // what the barometer reads above the true altitude, m
};

// Noise model, gates and initial uncertainty. Process noise is given as densities (per √Hz) so that it does
// not depend on the IMU rate; defaults() matches plant::SensorParams::defaults() (gyro 0.01 rad/s and accel
// 0.05 m/s² per 250 Hz sample ⇒ 6.3e-4 rad/s/√Hz and 3.2e-3 m/s²/√Hz), inflated a little for robustness.
struct EkfParams {
  // Process noise.
  double gyro_noise_rad_s_sqrt_hz = 1e-3;
  double accel_noise_m_s2_sqrt_hz = 5e-3;
  double gyro_bias_rw_rad_s2_sqrt_hz = 2e-4;  // bias random walk, (rad/s)/√s
  double accel_bias_rw_m_s3_sqrt_hz = 2e-3;   // bias random walk, (m/s²)/√s
  // A barometer drifts (temperature, weather): its bias walks, and taking its altitude as absolute lets the
  // estimate follow the drift (≈ 70 % of it, baro at 50 Hz against GPS height at 10 Hz). The plant's drift is
  // 0.002 m/√s; a little more here so the filter keeps up with a worse sensor.
  double baro_bias_rw_m_sqrt_s = 0.003;
  double gravity_m_s2 = 9.81;
  // Measurement noise (1σ). GPS position uses max(sample eph/epv, these floors).
  double gps_horizontal_noise_min_m = 0.05;
  double gps_vertical_noise_min_m = 0.1;
  double gps_velocity_noise_m_s = 0.07;
  double baro_noise_m = 0.15;
  double mag_heading_noise_rad = 0.05;
  double mag_declination_rad = 0.037175;  // 2.13°, east of north (jMAVSim's default origin, Zurich)
  double mag_inclination_rad = 1.105165;  // 63.32°, down from horizontal (idem)
  // GPS samples are this old when they arrive (PX4's EKF2_GPS_DELAY); the filter predicts the measurement
  // back to when it was taken instead of keeping a delayed state history. Must match the sensor's delay.
  Seconds gps_delay{0.2};
  // Innovation gates: normalised innovation squared (NIS = νᵀ S⁻¹ ν) against the χ² quantile for p = 1e-4.
  double gps_gate_chi2 = 27.86;   // 6 degrees of freedom (position + velocity)
  double baro_gate_chi2 = 15.14;  // 1 degree of freedom
  double mag_gate_chi2 = 15.14;   // 1 degree of freedom
  // After this many consecutive rejections of a sensor the filter trusts the sensor again: it resets the
  // states the sensor observes (GPS: p, v; baro: p_z; mag: yaw) to the measurement, with the measurement's
  // uncertainty (e.g. after a rollback left the estimate far from the truth, §III-A). 0.5 s at each rate.
  std::uint32_t gps_reset_after_rejections = 5;
  std::uint32_t baro_reset_after_rejections = 25;
  std::uint32_t mag_reset_after_rejections = 25;
  // Multirotor drag: the rotors push along −z_B only, so the horizontal specific force in B is the drag of
  // the air, f_B,xy = −(c/m) (R_NBᵀ v_N)_xy in calm air, plus the accelerometer's bias (PX4's EKF2 drag
  // fusion rests on the same fact). In a hover without yaw motion it is the only measurement that tells the
  // horizontal accelerometer bias from tilt: GPS sees g·δθ + R δb_a as one. Without it the estimate walks
  // along that unobservable direction as fast as the bias process noise lets it (its variance grows ∝ t), and
  // the tilt error moves the safety controller's hover away from x_sp until condition (1) cannot hold.
  //
  // c/m of the linear drag F = −c v_air [1/s] (jMAVSim's quad: 0.01 N·s/m over 0.8 kg).
  double drag_over_mass_per_s = 0.0125;
  // 1σ of what the linear law leaves out of one window's mean (wind, gusts) [m/s²].
  double drag_noise_m_s2 = 0.05;
  // The specific force is averaged over this window and the mean fused.
  Nanos drag_window{std::chrono::milliseconds{100}};
  double drag_gate_chi2 = 18.42;  // 2 degrees of freedom (x_B, y_B), p = 1e-4
  // Initial uncertainty (1σ).
  double initial_position_std_m = 1.0;
  double initial_velocity_std_m_s = 0.5;
  double initial_attitude_std_rad = 0.2;
  double initial_gyro_bias_std_rad_s = 0.01;
  double initial_accel_bias_std_m_s2 = 0.1;
  double initial_baro_bias_std_m = 0.05;

  [[nodiscard]] static EkfParams defaults();
};

// Outcome of one measurement update.
enum class FuseResult : std::uint8_t {
  Fused,     // the measurement passed its gate and corrected the state (also: a reset to the measurement)
  Rejected,  // the innovation failed its gate; the state is unchanged
};

// How often each sensor was fused, rejected by its gate, and used for a reset.
struct EkfCounters {
  std::uint32_t gps_fused = 0, gps_rejected = 0, gps_resets = 0;
  std::uint32_t baro_fused = 0, baro_rejected = 0, baro_resets = 0;
  std::uint32_t mag_fused = 0, mag_rejected = 0, mag_resets = 0;
  std::uint32_t drag_fused = 0, drag_rejected = 0;
};

// Error-state EKF with 16 error states (δp, δv, δθ, δb_g, δb_a, δb_baro); δθ is the attitude error as a rotation
// vector in B (q_true = q̂ ⊗ Exp(δθ)). predict() integrates the nominal state with the bias-corrected IMU and
// propagates the covariance blockwise (no dense 16×16 product). Each update is a χ² gate on the whole
// measurement, then a sequence of scalar updates (no matrix inverse). GPS is predicted back by gps_delay; the
// magnetometer corrects yaw only (tilt comes from the accelerometer and GPS; the drag constraint keeps the
// accelerometer's horizontal bias apart from tilt). A copyable VALUE type with no heap memory: the SR
// simulation checkpoints it by copy and restores it on rollback.
class Ekf {
 public:
  static constexpr int kStates = 16;
  using Covariance = Eigen::Matrix<double, kStates, kStates>;

  Ekf(const EkfParams& params, const EkfState& initial);

  // Propagates by dt with a gyro (rad/s, B) and accelerometer (specific force, m/s², B) sample.
  void predict(const Eigen::Vector3d& omega_B_rad_s, const Eigen::Vector3d& f_B_m_s2, Seconds dt);

  FuseResult fuse_gps(const plant::GpsSample& sample);
  FuseResult fuse_baro(const plant::BaroSample& sample);
  FuseResult fuse_mag(const plant::MagSample& sample);
  // Multirotor drag: adds the IMU's specific force (m/s², B, as given to predict) over dt to the current
  // window; once the window spans drag_window, fuses its mean and returns the outcome (nullopt until then).
  std::optional<FuseResult> fuse_drag(const Eigen::Vector3d& f_B_m_s2, Nanos dt);

  [[nodiscard]] const EkfState& state() const { return state_; }
  [[nodiscard]] const EkfParams& params() const { return params_; }
  [[nodiscard]] const EkfCounters& counters() const { return counters_; }
  // The gyro sample with the estimated bias removed: the body rate a controller should use, rad/s.
  [[nodiscard]] Eigen::Vector3d omega_B_corrected(const Eigen::Vector3d& raw_omega_B) const;
  // Acceleration of B in N estimated by the last predict(), m/s².
  [[nodiscard]] const Eigen::Vector3d& acceleration_N_m_s2() const { return a_N_; }
  // Error-state covariance, order: δp, δv, δθ, δb_g, δb_a, δb_baro.
  [[nodiscard]] const Covariance& covariance() const { return P_; }
  // NIS of the last GPS sample (fused or not), for tuning and tests.
  [[nodiscard]] double last_gps_nis() const { return last_gps_nis_; }

 private:
  using Vec = Eigen::Matrix<double, kStates, 1>;

  // One scalar update: innovation y (already measured against the nominal state), sparse row h, variance r.
  // Accumulates the correction in dx.
  void scalar_update(double y, const Vec& h, double r, Vec& dx);
  void inject(const Vec& dx);
  void reset_position_velocity(const plant::GpsSample& sample);

  EkfParams params_;
  EkfState state_;
  Covariance P_;
  Eigen::Vector3d a_N_ = Eigen::Vector3d::Zero();  // last estimated acceleration, m/s², N
  Eigen::Vector3d f_B_ = Eigen::Vector3d::Zero();  // last bias-corrected specific force, m/s², B
  EkfCounters counters_;
  std::uint32_t gps_rejected_in_row_ = 0;
  std::uint32_t baro_rejected_in_row_ = 0;
  std::uint32_t mag_rejected_in_row_ = 0;
  double last_gps_nis_ = 0;
  Eigen::Vector2d drag_f_dt_ = Eigen::Vector2d::Zero();  // ∫ f_B,xy dt over the current drag window [m/s]
  Nanos drag_span_{0};  // how long the current drag window is (integer ns: no rounding drift)
};

}  // namespace rejuv::flight
