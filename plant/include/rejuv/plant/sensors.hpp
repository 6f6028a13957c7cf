// Sensor models of the plant (docs/design.md §9; the SimpleSensors of jMAVSim used in §VI-A): gyro, accelerometer,
// magnetometer, barometer and GPS, each with white noise, a bias random walk, its own rate and a delay.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <random>
#include <string>

#include <Eigen/Core>

#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/plant/sensor_samples.hpp"

namespace rejuv::plant {

// Noise, bias, rate and delay of every sensor. `*_noise_*` is the standard deviation of the white noise of
// one sample (at that sensor's rate). A bias starts at a draw from N(0, *_bias_initial_std²) per axis
// (turn-on bias) and then walks with density *_bias_rw_* (σ grows as rw·√t). defaults() follows jMAVSim's
// default quad (Simulator.buildMulticopter: setNoise_Acc(0.05), setNoise_Gyo(0.01), setNoise_Mag(0.005),
// setNoise_Prs(0.1), GPS delay 200 ms, magnetic field of Zurich: inclination 63.32°, declination 2.13°);
// rates are those of PX4 SITL (gyro/accel 250 Hz, mag/baro 50 Hz, GPS 10 Hz). Values marked "assumed" are not
// from jMAVSim.
struct SensorParams {
  // Gyro.
  Nanos gyro_period{std::chrono::microseconds{4000}};  // 250 Hz
  Nanos gyro_delay{0};
  double gyro_noise_rad_s = 0.01;              // jMAVSim
  double gyro_bias_rw_rad_s_sqrt_s = 1e-4;     // assumed
  double gyro_bias_initial_std_rad_s = 0.003;  // assumed
  // Accelerometer.
  Nanos accel_period{std::chrono::microseconds{4000}};  // 250 Hz
  Nanos accel_delay{0};
  double accel_noise_m_s2 = 0.05;             // jMAVSim
  double accel_bias_rw_m_s2_sqrt_s = 1e-3;    // assumed
  double accel_bias_initial_std_m_s2 = 0.05;  // assumed
  // Magnetometer.
  Nanos mag_period{std::chrono::milliseconds{20}};  // 50 Hz
  Nanos mag_delay{0};
  double mag_noise_gauss = 0.005;         // jMAVSim
  double mag_bias_rw_gauss_sqrt_s = 0;    // assumed: calibrated, no drift
  double mag_bias_initial_std_gauss = 0;  // assumed: calibrated
  Eigen::Vector3d mag_field_N_gauss = field_from_inclination_declination(0.5, 63.32, 2.13);  // 0.5 G assumed
  // Barometer.
  Nanos baro_period{std::chrono::milliseconds{20}};  // 50 Hz
  Nanos baro_delay{0};
  double baro_noise_m = 0.1;             // jMAVSim (pressure-altitude noise)
  double baro_bias_rw_m_sqrt_s = 0.002;  // assumed: slow thermal drift
  double baro_bias_initial_std_m = 0;    // the EKF takes baro altitude as absolute
  double home_altitude_amsl_m = 488;     // jMAVSim's default origin (Zurich Irchel Park)
  // GPS (already projected to the local NED frame).
  Nanos gps_period{std::chrono::milliseconds{100}};  // 10 Hz
  Nanos gps_delay{std::chrono::milliseconds{200}};   // jMAVSim
  double gps_horizontal_noise_m = 0.05;  // assumed: modest (jMAVSim adds none); the SR switch needs it
  double gps_vertical_noise_m = 0.1;     // assumed
  double gps_velocity_noise_m_s = 0.05;  // assumed
  double gravity_m_s2 = 9.81;

  [[nodiscard]] static SensorParams defaults();
  // Earth's field in N from its strength, inclination (down from horizontal) and declination (east of north).
  [[nodiscard]] static Eigen::Vector3d field_from_inclination_declination(double strength_gauss,
                                                                          double inclination_deg,
                                                                          double declination_deg);
  // Checks periods > 0, delays >= 0 and short enough to queue, and noise/bias values >= 0; says which is
  // wrong.
  [[nodiscard]] Result<void, std::string> validate() const;
};

// What the sensors deliver in one physics step: each sensor at most one sample, most steps none.
struct SensorSamples {
  std::optional<GyroSample> gyro;
  std::optional<AccelSample> accel;
  std::optional<MagSample> mag;
  std::optional<BaroSample> baro;
  std::optional<GpsSample> gps;
};

// Samples are held back `delay` after they are measured; the queue is a fixed ring, so no allocation.
inline constexpr std::size_t kMaxQueuedSamples = 32;

// A FIFO of delayed samples of one sensor; part of SensorSuite's value.
template <class Sample>
class DelayLine {
 public:
  [[nodiscard]] bool push(const Sample& sample, Nanos release_at);  // false when full
  [[nodiscard]] std::optional<Sample> pop_ready(Nanos now);         // oldest, if its time has come

 private:
  struct Entry {
    Sample sample;
    Nanos release_at{};
  };
  std::array<Entry, kMaxQueuedSamples> ring_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

template <class Sample>
bool DelayLine<Sample>::push(const Sample& sample, Nanos release_at) {
  if (size_ == kMaxQueuedSamples) {
    return false;
  }
  ring_[(head_ + size_) % kMaxQueuedSamples] = Entry{sample, release_at};
  ++size_;
  return true;
}

template <class Sample>
std::optional<Sample> DelayLine<Sample>::pop_ready(Nanos now) {
  if (size_ == 0 || ring_[head_].release_at > now) {
    return std::nullopt;
  }
  const Sample out = ring_[head_].sample;
  head_ = (head_ + 1) % kMaxQueuedSamples;
  --size_;
  return out;
}

// All five sensors. Seeded and deterministic (one std::mt19937_64): the same seed and the same truth give the
// same samples. A copyable value type, so a simulation can checkpoint it.
class SensorSuite {
 public:
  // params must pass validate() (an internal invariant: check user input before).
  SensorSuite(const SensorParams& params, std::uint64_t seed);

  // Call every physics step with the time t, the true state and the true acceleration a_NB_N (m/s²). A sensor
  // measures when its period has elapsed and delivers the sample `delay` later.
  [[nodiscard]] SensorSamples step(Nanos t, const QuadState& truth, const Eigen::Vector3d& a_NB_N);

  [[nodiscard]] const SensorParams& params() const { return params_; }
  // True current biases (for evaluation and tests; a flight stack never sees them).
  [[nodiscard]] const Eigen::Vector3d& gyro_bias_B_rad_s() const { return gyro_bias_B_; }
  [[nodiscard]] const Eigen::Vector3d& accel_bias_B_m_s2() const { return accel_bias_B_; }
  [[nodiscard]] const Eigen::Vector3d& mag_bias_B_gauss() const { return mag_bias_B_; }
  [[nodiscard]] double baro_bias_m() const { return baro_bias_m_; }

 private:
  [[nodiscard]] double gauss();
  [[nodiscard]] Eigen::Vector3d gauss3();

  SensorParams params_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Eigen::Vector3d gyro_bias_B_;
  Eigen::Vector3d accel_bias_B_;
  Eigen::Vector3d mag_bias_B_;
  double baro_bias_m_ = 0;
  std::optional<Nanos> gyro_due_, accel_due_, mag_due_, baro_due_, gps_due_;  // next measurement times
  DelayLine<GyroSample> gyro_queue_;
  DelayLine<AccelSample> accel_queue_;
  DelayLine<MagSample> mag_queue_;
  DelayLine<BaroSample> baro_queue_;
  DelayLine<GpsSample> gps_queue_;
};

}  // namespace rejuv::plant
