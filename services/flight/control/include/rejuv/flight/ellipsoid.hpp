// The safety set of the SR scheme (§IV-A): the ellipsoid E(ρ, x_sp) = {x : (x − x_sp)ᵀ P (x − x_sp) ≤ ρ²}.
// P solves the closed-loop discrete Lyapunov equation A_clᵀ P A_cl − P = −Q of the safety controller
// (docs/design.md §9), so ‖e‖_P decreases along every step of safety control; it is then scaled so that E(1, ·) is the
// largest ellipsoid of that shape inside a state box |e_i| ≤ b_i. The extent of E(1, ·) along axis i is
// sqrt((P⁻¹)_ii), so the scale makes max_i (P⁻¹)_ii / b_i² = 1: the ellipsoid touches the box on at least one
// axis and stays inside it on all. "Safe" means V = ‖x − x_sp‖²_P < 1 for the true state.
#pragma once

#include <cstdint>
#include <string>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight/riccati.hpp"

namespace rejuv::flight {

// Half-widths b_i of the state box, one per state component, in the units of x.
struct StateBox {
  double position_m = graph_values::kBoxPosition.fallback;  // the defaults: rejuv/core/graph_values.hpp
  double velocity_m_s = graph_values::kBoxVelocity.fallback;
  double angle_rad = graph_values::kBoxAngle.fallback;
  double rate_rad_s = graph_values::kBoxRate.fallback;
  [[nodiscard]] StateVec half_widths() const;
};

enum class EllipsoidError : std::uint8_t { BadBox, NotPositiveDefinite, Lyapunov };
struct EllipsoidFailure {
  EllipsoidError kind;
  std::string message;
};

class SafetyEllipsoid {
 public:
  // P from A_clᵀ P A_cl − P = −Q, then scaled to the box. Refuses a non-positive or non-finite box, an
  // unstable A_cl and a P that is not positive definite.
  [[nodiscard]] static Result<SafetyEllipsoid, EllipsoidFailure> from_closed_loop(const StateMat& A_cl,
                                                                                 const StateMat& Q,
                                                                                 const StateBox& box);
  // The same with a diagonal Q chosen for the box: starting from Q = diag(1/b²), each Q_ii is multiplied by
  // (r_i / r̄)^½ with r_i = (P⁻¹)_ii / b_i² (r̄ their geometric mean) until every r_i is within 2 % of the largest,
  // so that the scaled E(1) touches every face of the box that the loop allows, not only the one of the fastest
  // or least weighted state (with Q from the LQR weights the fast rate states bind and E(1) is centimetres wide in
  // position). Weights stay within 10⁴ of each other, so −Q remains clearly negative definite.
  [[nodiscard]] static Result<SafetyEllipsoid, EllipsoidFailure> fitted_to_box(const StateMat& A_cl,
                                                                              const StateBox& box);
  // An ellipsoid from a given P (already scaled), for tests and for a P read from elsewhere.
  [[nodiscard]] static Result<SafetyEllipsoid, EllipsoidFailure> from_matrix(const StateMat& P);

  [[nodiscard]] const StateMat& P() const { return P_; }
  // V(e) = eᵀ P e = ‖e‖²_P.
  // (lazyProduct: a coefficient-wise 12×12 product, inlined; the general gemv kernel costs more than the
  // arithmetic at this size and V is evaluated every physics step.)
  [[nodiscard]] double V(const StateVec& e) const { return e.dot(P_.lazyProduct(e)); }
  // ‖x − center‖²_P with the yaw difference wrapped.
  [[nodiscard]] double V(const StateVec& x, const StateVec& center) const { return V(state_error(x, center)); }
  // ‖x − center‖_P.
  [[nodiscard]] double norm(const StateVec& x, const StateVec& center) const;
  // x ∈ E(ρ, center) ⇔ ‖x − center‖_P ≤ ρ.
  [[nodiscard]] bool contains(const StateVec& x, const StateVec& center, double rho) const;
  // Extent of E(1, ·) along each axis: sqrt((P⁻¹)_ii).
  [[nodiscard]] StateVec semi_axes_along_coordinates() const;
  // Residual of the Lyapunov equation before scaling (0 for from_matrix).
  [[nodiscard]] double lyapunov_residual() const { return lyapunov_residual_; }
  // The factor P was multiplied by to fit the box (1 for from_matrix).
  [[nodiscard]] double scale() const { return scale_; }
  // diag(Q) of the Lyapunov equation, before scaling (zero for from_matrix).
  [[nodiscard]] const StateVec& lyapunov_weights() const { return q_diag_; }

 private:
  SafetyEllipsoid(const StateMat& P, double scale, double residual, const StateVec& q_diag)
      : P_(P), scale_(scale), lyapunov_residual_(residual), q_diag_(q_diag) {}
  StateMat P_;
  double scale_ = 1;
  double lyapunov_residual_ = 0;
  StateVec q_diag_ = StateVec::Zero();
};

}  // namespace rejuv::flight
