#include "rejuv/flight/limits.hpp"

#include <Eigen/LU>
#include <cmath>

#include "rejuv/flight/detail/printf.hpp"

namespace rejuv::flight {

bool InputBox::contains(const InputVec& u, double tolerance) const {
  return ((u - lo).array() >= -tolerance).all() && ((hi - u).array() >= -tolerance).all();
}

std::array<InputVec, 16> InputBox::corners() const {
  std::array<InputVec, 16> out{};
  for (unsigned c = 0; c < 16U; ++c) {
    for (Eigen::Index j = 0; j < kInputDim; ++j) {
      out[c][j] = ((c >> static_cast<unsigned>(j)) & 1U) != 0U ? hi[j] : lo[j];
    }
  }
  return out;
}

InputBox full_limits(const VehicleParams& params) {
  InputBox box;
  const double tau_rp = params.arm_m * params.k1_N;
  const double tau_y = 2.0 * params.k2_N_m;
  box.lo << 0.0, -tau_rp, -tau_rp, -tau_y;
  box.hi << 4.0 * params.k1_N, tau_rp, tau_rp, tau_y;
  return box;
}

Result<InputBox, LimitsFailure> restricted_limits(const VehicleParams& params, double fraction) {
  if (!std::isfinite(fraction) || fraction <= 0.0 || fraction > 1.0) {
    return fail(LimitsFailure{LimitsError::BadFraction,
                              detail::printf_string("restricted_limit_fraction %g must be in (0, 1]", fraction)});
  }
  const InputBox full = full_limits(params);
  const InputVec h = hover_input(params);
  InputBox box;
  box.lo = h - fraction * (h - full.lo);
  box.hi = h + fraction * (full.hi - h);
  // Rotor levels of every corner through the inverse of the §IV-B mixer (the same matrix as plant::Mixer).
  const double k1 = params.k1_N, k2 = params.k2_N_m, L = params.arm_m;
  Eigen::Matrix4d M;
  M << k1, k1, k1, k1,  //
      0, -L * k1, 0, L * k1,  //
      L * k1, 0, -L * k1, 0,  //
      -k2, k2, -k2, k2;
  const Eigen::Matrix4d M_inv = M.inverse();
  for (const InputVec& corner : box.corners()) {
    const Eigen::Vector4d U = M_inv * corner;
    if ((U.array() < -1e-12).any() || (U.array() > 1.0 + 1e-12).any()) {
      return fail(LimitsFailure{
          LimitsError::NotMotorFeasible,
          detail::printf_string("restricted_limit_fraction %g: the corner u = [%.3f N, %.3f, %.3f, %.3f N·m] needs "
                                "rotor levels [%.3f, %.3f, %.3f, %.3f] outside [0, 1]",
                                fraction, corner[0], corner[1], corner[2], corner[3], U[0], U[1], U[2], U[3])});
    }
  }
  return box;
}

}  // namespace rejuv::flight
