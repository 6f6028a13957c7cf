// Wind of the plant (docs/design.md §9, "optional wind"): a mean plus first-order Gauss–Markov gusts per axis.
#pragma once

#include <cstdint>
#include <random>

#include <Eigen/Core>

#include "rejuv/core/time.hpp"

namespace rejuv::plant {

// Mean wind (air velocity in N, m/s) and gusts: per axis a first-order Gauss–Markov process with stationary
// standard deviation gust_std_m_s and correlation time gust_time_constant_s.
struct WindParams {
  Eigen::Vector3d mean_N_m_s = Eigen::Vector3d::Zero();
  double gust_std_m_s = 0;
  double gust_time_constant_s = 2;
};

// The mean wind as an air velocity in N: `speed_m_s` blowing toward `toward_deg`, degrees clockwise from north
// (0 = toward north, 90 = toward east). A wind reported as coming from θ (the meteorological way: a westerly is
// "from 270°") blows toward θ + 180°. The one conversion for the plant process and the model (`rejuv sim`).
[[nodiscard]] Eigen::Vector3d mean_wind_N(double speed_m_s, double toward_deg);

// Seeded, deterministic wind generator; a copyable value type. The gust is discretised exactly:
// g ← e^{−dt/τ} g + σ √(1 − e^{−2dt/τ}) n, n ~ N(0, 1), so its variance stays σ² for any dt.
class Wind {
 public:
  Wind(const WindParams& params, std::uint64_t seed);
  // Advances by dt and returns the wind velocity in N, m/s.
  Eigen::Vector3d step(Seconds dt);
  [[nodiscard]] Eigen::Vector3d current_N_m_s() const { return params_.mean_N_m_s + gust_N_m_s_; }

 private:
  WindParams params_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Eigen::Vector3d gust_N_m_s_ = Eigen::Vector3d::Zero();
};

}  // namespace rejuv::plant
