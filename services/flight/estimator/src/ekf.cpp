// Error-state EKF (docs/design.md §9; the ekf2 whose estimate x̂ drives the SR switching condition (1), §III-A).
#include "rejuv/flight/ekf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Cholesky>

#include "rejuv/core/result.hpp"

namespace rejuv::flight {

namespace {

// Offsets of the error-state blocks.
constexpr int kP = 0;
constexpr int kV = 3;
constexpr int kTheta = 6;
constexpr int kBg = 9;
constexpr int kBa = 12;
constexpr int kBb = 15;  // the barometer's bias (one state)

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0, -w.z(), w.y(),  //
      w.z(), 0, -w.x(),   //
      -w.y(), w.x(), 0;
  return S;
}

// exp of a rotation vector (rad) as a unit quaternion; first order near zero, where the axis is undefined.
Eigen::Quaterniond quat_from_rotvec(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle < 1e-9) {
    return Eigen::Quaterniond(1.0, 0.5 * r.x(), 0.5 * r.y(), 0.5 * r.z()).normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle));
}

double wrap_pi(double a) {
  return std::remainder(a, 2.0 * std::numbers::pi);
}

}  // namespace

EkfParams EkfParams::defaults() {
  return EkfParams{};
}

Ekf::Ekf(const EkfParams& params, const EkfState& initial) : params_(params), state_(initial) {
  state_.q_NB.normalize();
  Vec sigma;
  sigma << Eigen::Vector3d::Constant(params_.initial_position_std_m),
      Eigen::Vector3d::Constant(params_.initial_velocity_std_m_s),
      Eigen::Vector3d::Constant(params_.initial_attitude_std_rad),
      Eigen::Vector3d::Constant(params_.initial_gyro_bias_std_rad_s),
      Eigen::Vector3d::Constant(params_.initial_accel_bias_std_m_s2), params_.initial_baro_bias_std_m;
  P_ = sigma.cwiseAbs2().asDiagonal();
  // Until the first IMU sample, assume the vehicle is at rest: a = 0, f = −g.
  f_B_ = state_.q_NB.conjugate() * Eigen::Vector3d(0, 0, -params_.gravity_m_s2);
}

Eigen::Vector3d Ekf::omega_B_corrected(const Eigen::Vector3d& raw_omega_B) const {
  return raw_omega_B - state_.gyro_bias_rad_s;
}

// flatten: at -O2 GCC leaves Eigen's small fixed-size products as calls; inlining them all here makes
// predict, which runs at 250 Hz in a simulation that must beat 1000× real time, about 1.5× faster
// (ekf_bench).
[[gnu::flatten]] void Ekf::predict(const Eigen::Vector3d& omega_B_rad_s, const Eigen::Vector3d& f_B_m_s2,
                                   Seconds dt) {
  const double h = dt.count();
  if (!(h > 0.0)) {
    return;  // nothing to integrate (e.g. a duplicated IMU timestamp)
  }
  const Eigen::Vector3d w = omega_B_rad_s - state_.gyro_bias_rad_s;
  const Eigen::Vector3d f = f_B_m_s2 - state_.accel_bias_m_s2;
  const Eigen::Matrix3d R = state_.q_NB.toRotationMatrix();

  // Nominal state: strapdown integration with the IMU held over the interval.
  f_B_ = f;
  a_N_ = R * f + Eigen::Vector3d(0, 0, params_.gravity_m_s2);
  state_.p_N_m += state_.v_N_m_s * h + 0.5 * h * h * a_N_;
  state_.v_N_m_s += a_N_ * h;
  const Eigen::Quaterniond dq = quat_from_rotvec(w * h);
  state_.q_NB = (state_.q_NB * dq).normalized();

  // Error state transition F = I + A h, blockwise (Solà, "Quaternion kinematics for the error-state KF",
  // §5.3):
  //   δp' = δp + h δv
  //   δv' = δv + A δθ + B δb_a,       A = −R [f]× h,  B = −R h
  //   δθ' = C δθ − h δb_g,            C = exp(−[ω]× h) = R(ω h)ᵀ
  // P' = F P Fᵀ is formed by rows then columns, touching only the non-identity blocks (~700 multiply-adds
  // instead of 2·16³ for a dense product: predict runs at 250 Hz inside a simulation that must beat 1000×).
  // A δθ + B δb_a = −h R ([f]× δθ + δb_a): one 3×3 product per side instead of two, since B = −R h.
  const Eigen::Matrix3d f_skew = skew(f);
  const Eigen::Matrix3d minus_hR = -h * R;
  const Eigen::Matrix3d C = dq.toRotationMatrix().transpose();

  // Rows: X = F P (order matters: each block row only reads rows not yet overwritten).
  P_.middleRows<3>(kP) += h * P_.middleRows<3>(kV);
  {
    Eigen::Matrix<double, 3, kStates> T;
    T.noalias() = f_skew * P_.middleRows<3>(kTheta);
    T += P_.middleRows<3>(kBa);
    P_.middleRows<3>(kV).noalias() += minus_hR * T;
    T.noalias() = C * P_.middleRows<3>(kTheta);
    P_.middleRows<3>(kTheta) = T - h * P_.middleRows<3>(kBg);
  }
  // Columns: P' = X Fᵀ.
  P_.middleCols<3>(kP) += h * P_.middleCols<3>(kV);
  {
    Eigen::Matrix<double, kStates, 3> T;
    T.noalias() = P_.middleCols<3>(kTheta) * f_skew.transpose();
    T += P_.middleCols<3>(kBa);
    P_.middleCols<3>(kV).noalias() += T * minus_hR.transpose();
    T.noalias() = P_.middleCols<3>(kTheta) * C.transpose();
    P_.middleCols<3>(kTheta) = T - h * P_.middleCols<3>(kBg);
  }

  // Process noise Q: white IMU noise enters δv and δθ; the biases random-walk. Accelerometer noise is
  // isotropic, so R σ² I Rᵀ = σ² I.
  const double q_v = params_.accel_noise_m_s2_sqrt_hz * params_.accel_noise_m_s2_sqrt_hz * h;
  const double q_theta = params_.gyro_noise_rad_s_sqrt_hz * params_.gyro_noise_rad_s_sqrt_hz * h;
  const double q_bg = params_.gyro_bias_rw_rad_s2_sqrt_hz * params_.gyro_bias_rw_rad_s2_sqrt_hz * h;
  const double q_ba = params_.accel_bias_rw_m_s3_sqrt_hz * params_.accel_bias_rw_m_s3_sqrt_hz * h;
  for (int i = 0; i < 3; ++i) {
    P_(kV + i, kV + i) += q_v;
    P_(kTheta + i, kTheta + i) += q_theta;
    P_(kBg + i, kBg + i) += q_bg;
    P_(kBa + i, kBa + i) += q_ba;
  }
  P_(kBb, kBb) += params_.baro_bias_rw_m_sqrt_s * params_.baro_bias_rw_m_sqrt_s * h;
}

void Ekf::scalar_update(double y, const Vec& h, double r, Vec& dx) {
  // Sequential processing of uncorrelated scalar measurements is the same as the batch update, without
  // inverting S. y is measured against the nominal state; dx holds the corrections of earlier scalars.
  const Vec Ph = P_ * h;
  const double S = h.dot(Ph) + r;
  if (!(S > 0.0)) {
    return;  // degenerate (r = 0 and no uncertainty): nothing to learn
  }
  const Vec K = Ph / S;
  dx += K * (y - h.dot(dx));
  P_.noalias() -= K * Ph.transpose();
}

void Ekf::inject(const Vec& dx) {
  state_.p_N_m += dx.segment<3>(kP);
  state_.v_N_m_s += dx.segment<3>(kV);
  state_.q_NB = (state_.q_NB * quat_from_rotvec(dx.segment<3>(kTheta))).normalized();
  state_.gyro_bias_rad_s += dx.segment<3>(kBg);
  state_.accel_bias_m_s2 += dx.segment<3>(kBa);
  state_.baro_bias_m += dx(kBb);
  // Rounding makes the rank-1 downdates slightly asymmetric; restore symmetry once per measurement.
  P_ = (0.5 * (P_ + P_.transpose())).eval();
}

FuseResult Ekf::fuse_gps(const plant::GpsSample& sample) {
  // The sample is gps_delay old: predict the measurement back to when it was taken,
  //   p(t − d) ≈ p − v d + ½ a d²,  v(t − d) ≈ v − a d,  a = R̂ f + g,
  // so the rows of H also see δv, and through a (δa = −R̂ [f]× δθ − R̂ δb_a) the attitude and accelerometer
  // bias: a tilt error has already bent the velocity by g δθ d since the sample was taken.
  const double d = params_.gps_delay.count();
  const Eigen::Vector3d p_pred = state_.p_N_m - state_.v_N_m_s * d + 0.5 * d * d * a_N_;
  const Eigen::Vector3d v_pred = state_.v_N_m_s - a_N_ * d;
  Eigen::Matrix<double, 6, 1> y;
  y << sample.p_N_m - p_pred, sample.v_N_m_s - v_pred;

  const double sigma_h = std::max(sample.eph_m, params_.gps_horizontal_noise_min_m);
  const double sigma_v = std::max(sample.epv_m, params_.gps_vertical_noise_min_m);
  Eigen::Matrix<double, 6, 1> r;
  r << sigma_h * sigma_h, sigma_h * sigma_h, sigma_v * sigma_v,
      Eigen::Vector3d::Constant(params_.gps_velocity_noise_m_s * params_.gps_velocity_noise_m_s);

  const Eigen::Matrix3d R = state_.q_NB.toRotationMatrix();
  const Eigen::Matrix3d da_dtheta = -R * skew(f_B_);
  const Eigen::Matrix3d da_dba = -R;
  Eigen::Matrix<double, 6, kStates> H = Eigen::Matrix<double, 6, kStates>::Zero();
  H.block<3, 3>(0, kP).setIdentity();
  H.block<3, 3>(0, kV) = -d * Eigen::Matrix3d::Identity();
  H.block<3, 3>(0, kTheta) = 0.5 * d * d * da_dtheta;
  H.block<3, 3>(0, kBa) = 0.5 * d * d * da_dba;
  H.block<3, 3>(3, kV).setIdentity();
  H.block<3, 3>(3, kTheta) = -d * da_dtheta;
  H.block<3, 3>(3, kBa) = -d * da_dba;

  // χ² gate on the whole 6-vector: NIS = yᵀ S⁻¹ y with S = H P Hᵀ + R (a 6×6 Cholesky, at 10 Hz).
  const Eigen::Matrix<double, 6, kStates> HP = H * P_;
  Eigen::Matrix<double, 6, 6> S = HP * H.transpose();
  S.diagonal() += r;
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(S);
  last_gps_nis_ =
      llt.info() == Eigen::Success ? y.dot(llt.solve(y)) : std::numeric_limits<double>::infinity();

  if (!(last_gps_nis_ <= params_.gps_gate_chi2)) {
    ++counters_.gps_rejected;
    if (++gps_rejected_in_row_ < params_.gps_reset_after_rejections) {
      return FuseResult::Rejected;
    }
    reset_position_velocity(sample);
    return FuseResult::Fused;
  }
  gps_rejected_in_row_ = 0;

  Vec dx = Vec::Zero();
  for (int i = 0; i < 6; ++i) {
    scalar_update(y(i), H.row(i).transpose(), r(i), dx);
  }
  inject(dx);
  ++counters_.gps_fused;
  return FuseResult::Fused;
}

void Ekf::reset_position_velocity(const plant::GpsSample& sample) {
  // The estimate and the sensor disagree for longer than the gate allows: believe the sensor, forget the
  // correlations of position and velocity, and give them the measurement's uncertainty.
  const double d = params_.gps_delay.count();
  state_.v_N_m_s = sample.v_N_m_s + a_N_ * d;
  state_.p_N_m = sample.p_N_m + sample.v_N_m_s * d + 0.5 * d * d * a_N_;
  const double sigma_h = std::max(sample.eph_m, params_.gps_horizontal_noise_min_m);
  const double sigma_v = std::max(sample.epv_m, params_.gps_vertical_noise_min_m);
  P_.middleRows<6>(kP).setZero();
  P_.middleCols<6>(kP).setZero();
  P_(kP + 0, kP + 0) = sigma_h * sigma_h;
  P_(kP + 1, kP + 1) = sigma_h * sigma_h;
  P_(kP + 2, kP + 2) = sigma_v * sigma_v;
  const double var_v = params_.gps_velocity_noise_m_s * params_.gps_velocity_noise_m_s;
  for (int i = 0; i < 3; ++i) {
    P_(kV + i, kV + i) = var_v;
  }
  gps_rejected_in_row_ = 0;
  ++counters_.gps_resets;
}

FuseResult Ekf::fuse_baro(const plant::BaroSample& sample) {
  // The barometer reads the altitude −p_z plus its bias: h = −1 on δp_z, +1 on δb_baro.
  const double y = sample.altitude_m - (-state_.p_N_m.z() + state_.baro_bias_m);
  const double r = params_.baro_noise_m * params_.baro_noise_m;
  const double S = P_(kP + 2, kP + 2) + P_(kBb, kBb) - 2.0 * P_(kP + 2, kBb) + r;
  if (!(y * y <= params_.baro_gate_chi2 * S)) {
    ++counters_.baro_rejected;
    if (++baro_rejected_in_row_ < params_.baro_reset_after_rejections) {
      return FuseResult::Rejected;
    }
    // Believe the barometer (with the bias learnt so far): the altitude jumps, the bias stays.
    state_.p_N_m.z() = -(sample.altitude_m - state_.baro_bias_m);
    P_.row(kP + 2).setZero();
    P_.col(kP + 2).setZero();
    P_(kP + 2, kP + 2) = r;
    baro_rejected_in_row_ = 0;
    ++counters_.baro_resets;
    return FuseResult::Fused;
  }
  baro_rejected_in_row_ = 0;
  Vec h = Vec::Zero();
  h(kP + 2) = -1.0;
  h(kBb) = 1.0;
  Vec dx = Vec::Zero();
  scalar_update(y, h, r, dx);
  inject(dx);
  ++counters_.baro_fused;
  return FuseResult::Fused;
}

FuseResult Ekf::fuse_mag(const plant::MagSample& sample) {
  // Heading only: the measured field, rotated into N with the estimated attitude, has its horizontal
  // direction α at the declination δ when the estimate is right. With the attitude error expressed in N, φ_N
  // = R̂ δθ (R_true = R̂ Exp(δθ) = Exp(φ_N) R̂), the rotated field is Exp(−φ_N) b_N ≈ b_N − φ_N × b_N, turned by
  //   dα = (cos δ tan I) φ_x + (sin δ tan I) φ_y − φ_z,
  // where I is the inclination. Only the yaw term −φ_z is fused (as PX4's heading fusion does), so the
  // magnetometer never tilts the estimate: tilt comes from the accelerometer and GPS alone. The tilt terms
  // are instead treated as extra measurement noise: with I = 63° a tilt error shows up in the heading twice
  // as large, and ignoring it would make the filter overconfident in yaw while the tilt is still uncertain.
  const Eigen::Matrix3d R = state_.q_NB.toRotationMatrix();
  const Eigen::Vector3d b_N = R * sample.b_B_gauss;
  if (b_N.head<2>().norm() < 1e-6) {
    return FuseResult::Rejected;  // no horizontal field: no heading information
  }
  const double y = wrap_pi(std::atan2(b_N.y(), b_N.x()) - params_.mag_declination_rad);
  const double tan_incl = std::tan(params_.mag_inclination_rad);
  const Eigen::RowVector3d dalpha_dtilt_N(std::cos(params_.mag_declination_rad) * tan_incl,
                                          std::sin(params_.mag_declination_rad) * tan_incl, 0.0);
  const Eigen::RowVector3d h_tilt = dalpha_dtilt_N * R;  // d(α)/d(δθ) through tilt
  const Eigen::RowVector3d h_yaw = -R.row(2);            // d(α)/d(δθ) through yaw: −(R̂ δθ)_z
  Vec h = Vec::Zero();
  h.segment<3>(kTheta) = h_yaw.transpose();
  const double r = params_.mag_heading_noise_rad * params_.mag_heading_noise_rad +
                   (h_tilt * P_.block<3, 3>(kTheta, kTheta) * h_tilt.transpose())(0, 0);
  const double S = h.dot(P_ * h) + r;
  if (!(y * y <= params_.mag_gate_chi2 * S)) {
    ++counters_.mag_rejected;
    if (++mag_rejected_in_row_ < params_.mag_reset_after_rejections) {
      return FuseResult::Rejected;
    }
    // Turn the estimate about z_N so the field points at δ again (the heading error ψ̂ − ψ is y); the yaw
    // uncertainty grows by the measurement's, along the body-frame direction of z_N (a rotation a about z_N
    // is δθ = Rᵀ z_N a).
    state_.q_NB =
        (Eigen::Quaterniond(Eigen::AngleAxisd(-y, Eigen::Vector3d::UnitZ())) * state_.q_NB).normalized();
    const Eigen::Vector3d u = R.transpose().col(2);
    P_.block<3, 3>(kTheta, kTheta) += r * u * u.transpose();  // r includes the tilt uncertainty
    mag_rejected_in_row_ = 0;
    ++counters_.mag_resets;
    return FuseResult::Fused;
  }
  mag_rejected_in_row_ = 0;
  Vec dx = Vec::Zero();
  scalar_update(y, h, r, dx);
  inject(dx);
  ++counters_.mag_fused;
  return FuseResult::Fused;
}

std::optional<FuseResult> Ekf::fuse_drag(const Eigen::Vector3d& f_B_m_s2, Nanos dt) {
  if (dt <= Nanos{0}) {
    return std::nullopt;
  }
  drag_f_dt_ += f_B_m_s2.head<2>() * to_seconds(dt).count();
  drag_span_ += dt;
  if (drag_span_ < params_.drag_window) {
    return std::nullopt;
  }
  const double T = to_seconds(drag_span_).count();
  const Eigen::Vector2d f_mean = drag_f_dt_ / T;
  drag_f_dt_.setZero();
  drag_span_ = Nanos{0};

  // f_B,xy = b_a,xy − (c/m) (Rᵀ v)_xy. With R = R̂ Exp(δθ): Rᵀ v ≈ R̂ᵀ v + [R̂ᵀ v]× δθ, so the rows of H see
  // δb_a (identity), δv (−(c/m) R̂ᵀ) and δθ (−(c/m) [v_B]×); the last two are small in a hover but keep the
  // model exact.
  const double c_m = params_.drag_over_mass_per_s;
  const Eigen::Matrix3d R = state_.q_NB.toRotationMatrix();
  const Eigen::Vector3d v_B = R.transpose() * state_.v_N_m_s;
  const Eigen::Vector3d f_pred = state_.accel_bias_m_s2 - c_m * v_B;
  const Eigen::Matrix3d df_dv = -c_m * R.transpose();
  const Eigen::Matrix3d df_dtheta = -c_m * skew(v_B);
  Eigen::Matrix<double, 2, kStates> H = Eigen::Matrix<double, 2, kStates>::Zero();
  for (int i = 0; i < 2; ++i) {
    H.block<1, 3>(i, kV) = df_dv.row(i);
    H.block<1, 3>(i, kTheta) = df_dtheta.row(i);
    H(i, kBa + i) = 1.0;
  }
  const Eigen::Vector2d y = f_mean - f_pred.head<2>();
  // The mean of white accelerometer noise of density σ over T has variance σ²/T; the law's own error adds.
  const double r = params_.accel_noise_m_s2_sqrt_hz * params_.accel_noise_m_s2_sqrt_hz / T +
                   params_.drag_noise_m_s2 * params_.drag_noise_m_s2;

  Eigen::Matrix2d S = H * P_ * H.transpose();
  S.diagonal().array() += r;
  const Eigen::LLT<Eigen::Matrix2d> llt(S);
  const double nis =
      llt.info() == Eigen::Success ? y.dot(llt.solve(y)) : std::numeric_limits<double>::infinity();
  if (!(nis <= params_.drag_gate_chi2)) {
    ++counters_.drag_rejected;
    return FuseResult::Rejected;
  }
  Vec dx = Vec::Zero();
  for (int i = 0; i < 2; ++i) {
    scalar_update(y(i), H.row(i).transpose(), r, dx);
  }
  inject(dx);
  ++counters_.drag_fused;
  return FuseResult::Fused;
}

}  // namespace rejuv::flight
