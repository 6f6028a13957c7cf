#include "rejuv/flight/ellipsoid.hpp"

#include <Eigen/Cholesky>
#include <array>
#include <cmath>

#include "rejuv/flight/detail/printf.hpp"

namespace rejuv::flight {

StateVec StateBox::half_widths() const {
  StateVec b;
  b << Eigen::Vector3d::Constant(position_m), Eigen::Vector3d::Constant(velocity_m_s),
      Eigen::Vector3d::Constant(angle_rad), Eigen::Vector3d::Constant(rate_rad_s);
  return b;
}

namespace {

Result<StateMat, EllipsoidFailure> checked_inverse(const StateMat& P) {
  const Eigen::LLT<StateMat> llt(P);
  if (llt.info() != Eigen::Success || !P.allFinite()) {
    return fail(EllipsoidFailure{EllipsoidError::NotPositiveDefinite, "P is not symmetric positive definite"});
  }
  return llt.solve(StateMat::Identity());
}

}  // namespace

Result<SafetyEllipsoid, EllipsoidFailure> SafetyEllipsoid::from_closed_loop(const StateMat& A_cl, const StateMat& Q,
                                                                           const StateBox& box) {
  const StateVec b = box.half_widths();
  if (!b.allFinite() || (b.array() <= 0.0).any()) {
    return fail(EllipsoidFailure{EllipsoidError::BadBox, "every half-width of the state box must be positive"});
  }
  auto lyap = solve_discrete_lyapunov(A_cl, Q);
  if (!lyap) {
    return fail(EllipsoidFailure{EllipsoidError::Lyapunov, "closed-loop Lyapunov equation: " + lyap.error().message});
  }
  const StateMat P0 = lyap->P;
  auto P0_inv = checked_inverse(P0);
  if (!P0_inv) return fail(P0_inv.error());
  // E(1) of cP has extent sqrt((P⁻¹)_ii / c) along axis i: the largest c-scaled ellipsoid inside the box is the
  // one with c = max_i (P⁻¹)_ii / b_i², touching the box on the binding axis.
  const double c = (P0_inv->diagonal().array() / b.array().square()).maxCoeff();
  return SafetyEllipsoid(c * P0, c, lyap->residual, Q.diagonal());
}

Result<SafetyEllipsoid, EllipsoidFailure> SafetyEllipsoid::fitted_to_box(const StateMat& A_cl, const StateBox& box) {
  const StateVec b = box.half_widths();
  if (!b.allFinite() || (b.array() <= 0.0).any()) {
    return fail(EllipsoidFailure{EllipsoidError::BadBox, "every half-width of the state box must be positive"});
  }
  // P is linear in Q: P(diag(q)) = Σ_i q_i P_i with P_i the solution for e_i e_iᵀ. Twelve solves up front make
  // every step of the fit a weighted sum and a 12×12 inverse.
  std::array<StateMat, kStateDim> basis;
  for (Eigen::Index i = 0; i < kStateDim; ++i) {
    StateMat Ei = StateMat::Zero();
    Ei(i, i) = 1.0;
    auto lyap = solve_discrete_lyapunov(A_cl, Ei);
    if (!lyap) {
      return fail(EllipsoidFailure{EllipsoidError::Lyapunov, "closed-loop Lyapunov equation: " + lyap.error().message});
    }
    basis[static_cast<std::size_t>(i)] = lyap->P;
  }
  StateVec q = b.array().square().inverse().matrix();
  q /= q.maxCoeff();
  for (int iteration = 0; iteration < 300; ++iteration) {
    StateMat P = StateMat::Zero();
    for (Eigen::Index i = 0; i < kStateDim; ++i) P += q[i] * basis[static_cast<std::size_t>(i)];
    auto P_inv = checked_inverse(P);
    if (!P_inv) return fail(P_inv.error());
    const StateVec r = P_inv->diagonal().cwiseQuotient(b.cwiseProduct(b));
    if (r.minCoeff() >= 0.98 * r.maxCoeff()) break;
    const double mean_log = r.array().log().mean();
    q = q.cwiseProduct((r.array().log() - mean_log).exp().sqrt().matrix());
    q /= q.maxCoeff();  // only the shape matters; keep the numbers tame
    // Where the loop's dynamics tie two states together (a fast loop makes an angle error into a rate), no Q
    // can stretch the shadow further; keep every weight above 1e-4 of the largest so that V decreases along
    // every direction at a useful rate instead of chasing an unreachable shape.
    q = q.cwiseMax(1e-4);
  }
  auto fitted = from_closed_loop(A_cl, StateMat(q.asDiagonal()), box);
  if (!fitted) return fail(fitted.error());
  return *fitted;
}

Result<SafetyEllipsoid, EllipsoidFailure> SafetyEllipsoid::from_matrix(const StateMat& P) {
  if (!P.isApprox(P.transpose(), 1e-12)) {
    return fail(EllipsoidFailure{EllipsoidError::NotPositiveDefinite, "P is not symmetric"});
  }
  auto inv = checked_inverse(P);
  if (!inv) return fail(inv.error());
  return SafetyEllipsoid(P, 1.0, 0.0, StateVec::Zero());
}

double SafetyEllipsoid::norm(const StateVec& x, const StateVec& center) const {
  return std::sqrt(std::max(0.0, V(x, center)));
}

bool SafetyEllipsoid::contains(const StateVec& x, const StateVec& center, double rho) const {
  return V(x, center) <= rho * rho;
}

StateVec SafetyEllipsoid::semi_axes_along_coordinates() const {
  return P_.llt().solve(StateMat::Identity()).diagonal().cwiseSqrt();
}

}  // namespace rejuv::flight
