#include "rejuv/flight/output_driver.hpp"

#include <algorithm>

namespace rejuv::flight {

OutputDriver::OutputDriver(const Eigen::Matrix4d& mixer_inverse, const InputBox& full, const InputBox& restricted,
                           const InputVec& initial_u)
    : mixer_inverse_(mixer_inverse), full_(full), restricted_(restricted), u_(full.clamp(initial_u)) {
  motors_ = (mixer_inverse_ * u_).cwiseMax(0.0).cwiseMin(1.0);
}

void OutputDriver::publish(Nanos t, const InputVec& u) {
  switch (limits_) {
    case LimitSet::Full: u_ = full_.clamp(u); break;
    case LimitSet::Restricted: u_ = restricted_.clamp(u); break;
  }
  // Each rotor saturates at 0 and 100 %: what the plant can do with a corner of U (Ū is checked to be inside).
  motors_ = (mixer_inverse_ * u_).cwiseMax(0.0).cwiseMin(1.0);
  if (last_publish_) max_gap_ = std::max(max_gap_, t - *last_publish_);
  last_publish_ = t;
}

}  // namespace rejuv::flight
