#include "rejuv/flight/lqr_controller.hpp"

#include "rejuv/flight/detail/printf.hpp"

namespace rejuv::flight {

Result<LqrController, RiccatiFailure> LqrController::design(const DiscreteModel& model, const LqrWeights& weights,
                                                            const InputVec& u_hover, const InputBox& limits) {
  if (!weights.q_diag.allFinite() || (weights.q_diag.array() < 0.0).any() || !weights.r_diag.allFinite() ||
      (weights.r_diag.array() <= 0.0).any()) {
    return fail(RiccatiFailure{RiccatiError::Singular, "LQR weights: q must be >= 0 and r > 0, all finite"});
  }
  const StateMat Q = weights.q_diag.asDiagonal();
  const Eigen::Matrix4d R = weights.r_diag.asDiagonal();
  auto dare = solve_dare(model.A, model.B, Q, R);
  if (!dare) return fail(dare.error());
  LqrController c;
  c.K_ = dare->K;
  c.X_ = dare->X;
  c.residual_ = dare->residual;
  c.A_cl_ = model.A - model.B * c.K_;
  c.u_hover_ = u_hover;
  c.limits_ = limits;
  const double rho = spectral_radius(c.A_cl_);
  if (!(rho < 1.0)) {
    return fail(RiccatiFailure{RiccatiError::NotStable,
                               detail::printf_string("closed loop A - BK has spectral radius %.6f", rho)});
  }
  return c;
}

InputVec LqrController::unclamped(const StateVec& x_hat, const StateVec& x_sp) const {
  return u_hover_ - K_ * state_error(x_hat, x_sp);
}

LqrController LqrController::with_gain(const GainMat& K) const {
  LqrController c = *this;
  c.K_ = K;
  return c;
}

InputVec LqrController::control(const StateVec& x_hat, const StateVec& x_sp) const {
  return limits_.clamp(unclamped(x_hat, x_sp));
}

}  // namespace rejuv::flight
