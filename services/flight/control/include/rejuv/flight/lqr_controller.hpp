// A discrete LQR state-feedback controller about hover, saturated to an input box (docs/design.md §9; §IV-B: the
// paper replaced PX4's attitude and rate controllers by `lqr_control`). The same type serves as the mission
// controller (gentle, clamped to Ū in MC) and the safety controller (aggressive, full limits U in SC).
// Stateless by design: all the memory the SR scheme must checkpoint lives in the estimator and the setpoint
// generator, so a rollback restores the controller exactly.
#pragma once

#include <cstdint>
#include <string>

#include "rejuv/core/result.hpp"
#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight/limits.hpp"
#include "rejuv/flight/riccati.hpp"

namespace rejuv::flight {

// Diagonal LQR weights: J = Σ eᵀ diag(q) e + δuᵀ diag(r) δu.
struct LqrWeights {
  StateVec q_diag = StateVec::Ones();
  InputVec r_diag = InputVec::Ones();
};

class LqrController {
 public:
  // Solves the DARE on `model` with `weights`; the gain is refused if the DARE residual is not small or the
  // closed loop A − BK is not Schur stable.
  [[nodiscard]] static Result<LqrController, RiccatiFailure> design(const DiscreteModel& model,
                                                                  const LqrWeights& weights,
                                                                  const InputVec& u_hover, const InputBox& limits);

  // u = clamp(u_hover − K (x̂ − x_sp)).
  [[nodiscard]] InputVec control(const StateVec& x_hat, const StateVec& x_sp) const;
  // The same without the clamp (what the linear law asks for).
  [[nodiscard]] InputVec unclamped(const StateVec& x_hat, const StateVec& x_sp) const;

  [[nodiscard]] const GainMat& K() const { return K_; }
  // The same controller with its gain replaced by K (the attack library's GAIN_OVERWRITE: a compromised
  // controller's memory; attack_library.hpp). Nothing is checked: the point is a gain no design made.
  [[nodiscard]] LqrController with_gain(const GainMat& K) const;
  [[nodiscard]] const StateMat& closed_loop() const { return A_cl_; }  // A − B K
  [[nodiscard]] const StateMat& riccati_X() const { return X_; }
  [[nodiscard]] double dare_residual() const { return residual_; }
  [[nodiscard]] const InputBox& limits() const { return limits_; }
  [[nodiscard]] const InputVec& u_hover() const { return u_hover_; }

 private:
  LqrController() = default;
  GainMat K_ = GainMat::Zero();
  StateMat A_cl_ = StateMat::Zero();
  StateMat X_ = StateMat::Zero();
  double residual_ = 0;
  InputVec u_hover_ = InputVec::Zero();
  InputBox limits_;
};

}  // namespace rejuv::flight
