#include "rejuv/flight/attack.hpp"

namespace rejuv::flight {

InputVec worst_case_corner(const InputBox& box, const StateMat& P, const InputMat& B, const StateVec& e) {
  // V̇ depends on u only through 2 eᵀPB u, separable per component: each one at the bound its gradient favours.
  const InputVec gradient = B.transpose() * (P * e);
  InputVec u;
  for (Eigen::Index j = 0; j < kInputDim; ++j) {
    u[j] = gradient[j] >= 0.0 ? box.hi[j] : box.lo[j];
  }
  return u;
}

double lyapunov_rate(const LinearModel& model, const StateMat& P, const StateVec& e, const InputVec& u,
                     const InputVec& u_hover) {
  return 2.0 * e.dot(P * (model.A * e + model.B * (u - u_hover)));
}

}  // namespace rejuv::flight
