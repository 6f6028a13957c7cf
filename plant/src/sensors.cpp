// Sensor models (docs/design.md §9; jMAVSim's SimpleSensors, §VI-A): truth + bias + white noise, sampled at each
// sensor's rate and delivered after its delay.
#include "rejuv/plant/sensors.hpp"

#include <cmath>
#include <numbers>

namespace rejuv::plant {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

// Standard atmosphere (ISA, troposphere): static pressure at an altitude above mean sea level, Pa.
double isa_pressure_pa(double altitude_amsl_m) {
  return 101325.0 * std::pow(1.0 - 2.25577e-5 * altitude_amsl_m, 5.25588);
}

// Whether a sensor with this period measures at t; advances its next due time. The first call measures.
bool due(std::optional<Nanos>& next, Nanos period, Nanos t) {
  if (!next) {
    next = t;
  }
  if (t < *next) {
    return false;
  }
  *next += period;
  if (*next <= t) {  // the caller skipped more than a period: resume the grid from now
    *next = t + period;
  }
  return true;
}

double sqrt_seconds(Nanos period) {
  return std::sqrt(to_seconds(period).count());
}

}  // namespace

SensorParams SensorParams::defaults() {
  return SensorParams{};
}

Eigen::Vector3d SensorParams::field_from_inclination_declination(double strength_gauss,
                                                                 double inclination_deg,
                                                                 double declination_deg) {
  const double incl = inclination_deg * kDegToRad;
  const double decl = declination_deg * kDegToRad;
  // NED: horizontal component points declination east of north, the vertical one down (northern hemisphere).
  return strength_gauss *
         Eigen::Vector3d(std::cos(incl) * std::cos(decl), std::cos(incl) * std::sin(decl), std::sin(incl));
}

Result<void, std::string> SensorParams::validate() const {
  struct Timing {
    const char* name;
    Nanos period;
    Nanos delay;
  };
  for (const Timing& s : {Timing{"gyro", gyro_period, gyro_delay}, Timing{"accel", accel_period, accel_delay},
                          Timing{"mag", mag_period, mag_delay}, Timing{"baro", baro_period, baro_delay},
                          Timing{"gps", gps_period, gps_delay}}) {
    if (s.period <= Nanos{0}) {
      return fail(std::string(s.name) + "_period must be > 0");
    }
    if (s.delay < Nanos{0}) {
      return fail(std::string(s.name) + "_delay must be >= 0");
    }
    // Samples in flight: delay/period of them, plus the one measured in the step it is released.
    if (s.delay / s.period + 2 > static_cast<std::int64_t>(kMaxQueuedSamples)) {
      return fail(std::string(s.name) + "_delay must be shorter than " +
                  std::to_string(kMaxQueuedSamples - 2) + " sample periods");
    }
  }
  struct NonNegative {
    const char* name;
    double value;
  };
  for (const NonNegative& v : {NonNegative{"gyro_noise_rad_s", gyro_noise_rad_s},
                               NonNegative{"gyro_bias_rw_rad_s_sqrt_s", gyro_bias_rw_rad_s_sqrt_s},
                               NonNegative{"gyro_bias_initial_std_rad_s", gyro_bias_initial_std_rad_s},
                               NonNegative{"accel_noise_m_s2", accel_noise_m_s2},
                               NonNegative{"accel_bias_rw_m_s2_sqrt_s", accel_bias_rw_m_s2_sqrt_s},
                               NonNegative{"accel_bias_initial_std_m_s2", accel_bias_initial_std_m_s2},
                               NonNegative{"mag_noise_gauss", mag_noise_gauss},
                               NonNegative{"mag_bias_rw_gauss_sqrt_s", mag_bias_rw_gauss_sqrt_s},
                               NonNegative{"mag_bias_initial_std_gauss", mag_bias_initial_std_gauss},
                               NonNegative{"baro_noise_m", baro_noise_m},
                               NonNegative{"baro_bias_rw_m_sqrt_s", baro_bias_rw_m_sqrt_s},
                               NonNegative{"baro_bias_initial_std_m", baro_bias_initial_std_m},
                               NonNegative{"gps_horizontal_noise_m", gps_horizontal_noise_m},
                               NonNegative{"gps_vertical_noise_m", gps_vertical_noise_m},
                               NonNegative{"gps_velocity_noise_m_s", gps_velocity_noise_m_s}}) {
    if (!(v.value >= 0.0)) {  // also rejects NaN
      return fail(std::string(v.name) + " must be >= 0");
    }
  }
  return {};
}

SensorSuite::SensorSuite(const SensorParams& params, std::uint64_t seed) : params_(params), rng_(seed) {
  REJUV_ASSERT(params_.validate().has_value(), "SensorParams must be validated before use");
  gyro_bias_B_ = params_.gyro_bias_initial_std_rad_s * gauss3();
  accel_bias_B_ = params_.accel_bias_initial_std_m_s2 * gauss3();
  mag_bias_B_ = params_.mag_bias_initial_std_gauss * gauss3();
  baro_bias_m_ = params_.baro_bias_initial_std_m * gauss();
}

double SensorSuite::gauss() {
  return normal_(rng_);
}

Eigen::Vector3d SensorSuite::gauss3() {
  // Drawn one by one (not Eigen's NullaryExpr) so the order of draws is fixed: determinism for a seed.
  const double x = gauss();
  const double y = gauss();
  const double z = gauss();
  return {x, y, z};
}

SensorSamples SensorSuite::step(Nanos t, const QuadState& truth, const Eigen::Vector3d& a_NB_N) {
  const auto enqueue = [t](auto& queue, const auto& sample, Nanos delay) {
    const bool queued = queue.push(sample, t + delay);
    REJUV_ASSERT(queued, "sensor delay queue overflow (validate() bounds delay/period)");
  };

  if (due(gyro_due_, params_.gyro_period, t)) {
    gyro_bias_B_ += params_.gyro_bias_rw_rad_s_sqrt_s * sqrt_seconds(params_.gyro_period) * gauss3();
    const GyroSample s{t, truth.omega_B_rad_s + gyro_bias_B_ + params_.gyro_noise_rad_s * gauss3()};
    enqueue(gyro_queue_, s, params_.gyro_delay);
  }
  if (due(accel_due_, params_.accel_period, t)) {
    accel_bias_B_ += params_.accel_bias_rw_m_s2_sqrt_s * sqrt_seconds(params_.accel_period) * gauss3();
    // Specific force: what the proof mass feels, a − g (reads −g·z_N, i.e. "up", at rest).
    const Eigen::Vector3d f_N = a_NB_N - Eigen::Vector3d(0, 0, params_.gravity_m_s2);
    const AccelSample s{t,
                        truth.q_NB.conjugate() * f_N + accel_bias_B_ + params_.accel_noise_m_s2 * gauss3()};
    enqueue(accel_queue_, s, params_.accel_delay);
  }
  if (due(mag_due_, params_.mag_period, t)) {
    mag_bias_B_ += params_.mag_bias_rw_gauss_sqrt_s * sqrt_seconds(params_.mag_period) * gauss3();
    const MagSample s{t, truth.q_NB.conjugate() * params_.mag_field_N_gauss + mag_bias_B_ +
                             params_.mag_noise_gauss * gauss3()};
    enqueue(mag_queue_, s, params_.mag_delay);
  }
  if (due(baro_due_, params_.baro_period, t)) {
    baro_bias_m_ += params_.baro_bias_rw_m_sqrt_s * sqrt_seconds(params_.baro_period) * gauss();
    const double altitude_m = -truth.p_NB_N.z() + baro_bias_m_ + params_.baro_noise_m * gauss();
    const BaroSample s{t, altitude_m, isa_pressure_pa(params_.home_altitude_amsl_m + altitude_m)};
    enqueue(baro_queue_, s, params_.baro_delay);
  }
  if (due(gps_due_, params_.gps_period, t)) {
    const Eigen::Vector3d n_p = gauss3();
    const Eigen::Vector3d n_v = gauss3();
    GpsSample s;
    s.t = t;
    s.p_N_m = truth.p_NB_N + Eigen::Vector3d(params_.gps_horizontal_noise_m * n_p.x(),
                                             params_.gps_horizontal_noise_m * n_p.y(),
                                             params_.gps_vertical_noise_m * n_p.z());
    s.v_N_m_s = truth.v_NB_N + params_.gps_velocity_noise_m_s * n_v;
    s.eph_m = params_.gps_horizontal_noise_m;
    s.epv_m = params_.gps_vertical_noise_m;
    enqueue(gps_queue_, s, params_.gps_delay);
  }

  SensorSamples out;
  out.gyro = gyro_queue_.pop_ready(t);
  out.accel = accel_queue_.pop_ready(t);
  out.mag = mag_queue_.pop_ready(t);
  out.baro = baro_queue_.pop_ready(t);
  out.gps = gps_queue_.pop_ready(t);
  return out;
}

}  // namespace rejuv::plant
