// Discrete-time Riccati and Lyapunov equations, solved with Eigen at start-up (docs/design.md §9): the gains of the
// mission and safety LQRs and the matrix P of the safety ellipsoid. Every solution comes with its residual so
// that a caller (and the tests) can check it instead of trusting the iteration.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "rejuv/core/result.hpp"

namespace rejuv::flight {

enum class RiccatiError : std::uint8_t {
  BadDimensions,  // A not square, B/Q/R not matching
  NotFinite,      // NaN or Inf in an input or in an iterate
  Singular,       // a matrix that must be inverted is singular (R not > 0, or I + G H singular)
  NotConverged,   // the iteration did not settle, or the residual is too large (e.g. (A, B) not stabilisable)
  NotStable,      // Lyapunov: A has an eigenvalue on or outside the unit circle
};
[[nodiscard]] std::string to_string(RiccatiError error);

struct RiccatiFailure {
  RiccatiError kind;
  std::string message;
};

// X of the DARE X = AᵀXA − AᵀXB (R + BᵀXB)⁻¹ BᵀXA + Q, and the LQR gain K = (R + BᵀXB)⁻¹ BᵀXA for u = −K x.
struct DareSolution {
  Eigen::MatrixXd X;
  Eigen::MatrixXd K;
  double residual = 0;  // ‖AᵀXA − X − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q‖_F / max(1, ‖X‖_F)
  int iterations = 0;
};

// Structured doubling algorithm (quadratic convergence; robust for A close to I as at a fast control rate).
// Requires Q ⪰ 0, R ≻ 0, (A, B) stabilisable and (A, Q^½) detectable; refuses with NotConverged otherwise.
[[nodiscard]] Result<DareSolution, RiccatiFailure> solve_dare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                              const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R);

// Relative residual of the DARE at X (the same definition as DareSolution::residual).
[[nodiscard]] double dare_residual(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                                   const Eigen::MatrixXd& R, const Eigen::MatrixXd& X);

// P of the discrete Lyapunov equation AᵀPA − P = −Q, for A Schur stable (spectral radius < 1).
struct LyapunovSolution {
  Eigen::MatrixXd P;
  double residual = 0;  // ‖AᵀPA − P + Q‖_F / max(1, ‖P‖_F)
};
[[nodiscard]] Result<LyapunovSolution, RiccatiFailure> solve_discrete_lyapunov(const Eigen::MatrixXd& A,
                                                                               const Eigen::MatrixXd& Q);

// max |λ_i(A)|.
[[nodiscard]] double spectral_radius(const Eigen::MatrixXd& A);

}  // namespace rejuv::flight
