#include "rejuv/flight/riccati.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "rejuv/flight/detail/printf.hpp"

namespace rejuv::flight {

std::string to_string(RiccatiError error) {
  switch (error) {
    case RiccatiError::BadDimensions: return "bad dimensions";
    case RiccatiError::NotFinite: return "not finite";
    case RiccatiError::Singular: return "singular";
    case RiccatiError::NotConverged: return "not converged";
    case RiccatiError::NotStable: return "not stable";
  }
  return "unknown";
}

namespace {

RiccatiFailure failure(RiccatiError kind, std::string message) { return {kind, std::move(message)}; }

// Relative tolerance of a DARE/Lyapunov solution that callers may rely on.
constexpr double kResidualTolerance = 1e-8;

}  // namespace

double dare_residual(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                     const Eigen::MatrixXd& R, const Eigen::MatrixXd& X) {
  const Eigen::MatrixXd BtXA = B.transpose() * X * A;
  const Eigen::MatrixXd S = R + B.transpose() * X * B;
  const Eigen::MatrixXd res = A.transpose() * X * A - X - BtXA.transpose() * S.ldlt().solve(BtXA) + Q;
  return res.norm() / std::max(1.0, X.norm());
}

Result<DareSolution, RiccatiFailure> solve_dare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R) {
  const Eigen::Index n = A.rows();
  const Eigen::Index m = B.cols();
  if (A.cols() != n || B.rows() != n || Q.rows() != n || Q.cols() != n || R.rows() != m || R.cols() != m || n == 0 ||
      m == 0) {
    return fail(failure(RiccatiError::BadDimensions, "A n×n, B n×m, Q n×n, R m×m expected"));
  }
  if (!A.allFinite() || !B.allFinite() || !Q.allFinite() || !R.allFinite()) {
    return fail(failure(RiccatiError::NotFinite, "an input matrix holds NaN or Inf"));
  }
  const Eigen::LLT<Eigen::MatrixXd> R_llt(0.5 * (R + R.transpose()));
  if (R_llt.info() != Eigen::Success) {
    return fail(failure(RiccatiError::Singular, "R must be symmetric positive definite"));
  }
  // Structured doubling (Chu, Fan, Lin 2005): A_{k+1} = A_k W⁻¹ A_k, G_{k+1} = G_k + A_k W⁻¹ G_k A_kᵀ,
  // H_{k+1} = H_k + A_kᵀ H_k W⁻¹ A_k with W = I + G_k H_k; H_k → X quadratically.
  Eigen::MatrixXd Ak = A;
  Eigen::MatrixXd Gk = B * R_llt.solve(B.transpose());
  Eigen::MatrixXd Hk = 0.5 * (Q + Q.transpose());
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  int it = 0;
  bool settled = false;
  for (it = 1; it <= 100; ++it) {
    const Eigen::PartialPivLU<Eigen::MatrixXd> W(I + Gk * Hk);
    if (!std::isfinite(W.rcond()) || W.rcond() < 1e-14) {
      return fail(failure(RiccatiError::Singular, "I + G H became singular in the doubling iteration"));
    }
    const Eigen::MatrixXd WinvA = W.solve(Ak);
    const Eigen::MatrixXd WinvG = W.solve(Gk);
    const Eigen::MatrixXd H_next = Hk + Ak.transpose() * Hk * WinvA;
    Gk = Gk + Ak * WinvG * Ak.transpose();
    Ak = Ak * WinvA;
    const double change = (H_next - Hk).norm();
    Hk = 0.5 * (H_next + H_next.transpose());
    if (!Hk.allFinite() || !Gk.allFinite() || !Ak.allFinite()) {
      return fail(failure(RiccatiError::NotFinite, "the doubling iteration diverged"));
    }
    if (change <= 1e-13 * std::max(1.0, Hk.norm())) {
      settled = true;
      break;
    }
  }
  if (!settled) {
    return fail(failure(RiccatiError::NotConverged,
                        "the doubling iteration did not settle in 100 steps ((A, B) not stabilisable?)"));
  }
  DareSolution sol;
  sol.X = Hk;
  sol.iterations = it;
  const Eigen::MatrixXd S = R + B.transpose() * sol.X * B;
  sol.K = S.ldlt().solve(B.transpose() * sol.X * A);
  sol.residual = dare_residual(A, B, Q, R, sol.X);
  if (!(sol.residual <= kResidualTolerance)) {
    return fail(failure(RiccatiError::NotConverged, detail::printf_string("DARE residual %.3g too large", sol.residual)));
  }
  return sol;
}

double spectral_radius(const Eigen::MatrixXd& A) {
  const Eigen::EigenSolver<Eigen::MatrixXd> es(A, /*computeEigenvectors=*/false);
  return es.eigenvalues().cwiseAbs().maxCoeff();
}

Result<LyapunovSolution, RiccatiFailure> solve_discrete_lyapunov(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q) {
  const Eigen::Index n = A.rows();
  if (A.cols() != n || Q.rows() != n || Q.cols() != n || n == 0) {
    return fail(failure(RiccatiError::BadDimensions, "A and Q must be square of the same size"));
  }
  if (!A.allFinite() || !Q.allFinite()) {
    return fail(failure(RiccatiError::NotFinite, "an input matrix holds NaN or Inf"));
  }
  const double rho = spectral_radius(A);
  if (!(rho < 1.0)) {
    return fail(failure(RiccatiError::NotStable, detail::printf_string("spectral radius %.6f is not below 1", rho)));
  }
  // Smith's doubling: P = Σ_k (Aᵀ)ᵏ Q Aᵏ, summed as P ← P + A_kᵀ P A_k, A_k ← A_k², which doubles the number of
  // terms per step; 2⁶⁴ terms would outlast any spectral radius that double precision can tell from 1.
  const Eigen::MatrixXd Qs = 0.5 * (Q + Q.transpose());
  Eigen::MatrixXd P = Qs;
  Eigen::MatrixXd Ak = A;
  for (int k = 0; k < 64; ++k) {
    const Eigen::MatrixXd increment = Ak.transpose() * P * Ak;
    P += increment;
    Ak = Ak * Ak;
    if (increment.norm() <= 1e-17 * P.norm()) break;
  }
  const Eigen::MatrixXd At = A.transpose();
  LyapunovSolution sol;
  sol.P = 0.5 * (P + P.transpose());
  sol.residual = (At * sol.P * A - sol.P + Qs).norm() / std::max(1.0, sol.P.norm());
  if (!sol.P.allFinite() || !(sol.residual <= kResidualTolerance)) {
    return fail(failure(RiccatiError::NotConverged,
                        detail::printf_string("Lyapunov residual %.3g too large (A nearly unstable?)", sol.residual)));
  }
  return sol;
}

}  // namespace rejuv::flight
