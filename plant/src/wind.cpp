// Wind: mean + first-order Gauss–Markov gusts (docs/design.md §9).
#include "rejuv/plant/wind.hpp"

#include <cmath>
#include <numbers>

#include "rejuv/core/result.hpp"

namespace rejuv::plant {

Eigen::Vector3d mean_wind_N(double speed_m_s, double toward_deg) {
  const double a = toward_deg * std::numbers::pi / 180.0;
  return {speed_m_s * std::cos(a), speed_m_s * std::sin(a), 0.0};
}

Wind::Wind(const WindParams& params, std::uint64_t seed) : params_(params), rng_(seed) {
  REJUV_ASSERT(params.gust_std_m_s >= 0 && params.gust_time_constant_s > 0,
               "wind gusts need std >= 0 and time constant > 0");
  // Start in the stationary distribution, so the statistics do not depend on how long the wind has run.
  for (int i = 0; i < 3; ++i) {
    gust_N_m_s_(i) = params_.gust_std_m_s * normal_(rng_);
  }
}

Eigen::Vector3d Wind::step(Seconds dt) {
  const double phi = std::exp(-dt.count() / params_.gust_time_constant_s);
  const double drive = params_.gust_std_m_s * std::sqrt(1.0 - phi * phi);
  for (int i = 0; i < 3; ++i) {
    gust_N_m_s_(i) = phi * gust_N_m_s_(i) + drive * normal_(rng_);
  }
  return current_N_m_s();
}

}  // namespace rejuv::plant
