// The worst-case control attack of §VI-D: "minimum time optimal control actions that push the system outside
// the safety set as fast as possible". With V = ‖x − x_sp‖²_P and the hover model ẋ = A e + B δu,
// V̇ = 2 eᵀ P (A e + B δu) is linear in u, so over the box Ū it is maximised at the corner whose component j is
// hi_j where (BᵀPe)_j > 0 and lo_j where it is < 0 (docs/design.md §9). The compromised controller evaluates it with its
// own estimate x̂ in every MC window it controls.
#pragma once

#include "rejuv/flight/ellipsoid.hpp"
#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight/limits.hpp"

namespace rejuv::flight {

// The corner of `box` that maximises eᵀ P B u (ties: hi).
[[nodiscard]] InputVec worst_case_corner(const InputBox& box, const StateMat& P, const InputMat& B,
                                         const StateVec& e);

// V̇ = 2 eᵀ P (A e + B (u − u_hover)) for the continuous hover model (the quantity the attack maximises).
[[nodiscard]] double lyapunov_rate(const LinearModel& model, const StateMat& P, const StateVec& e,
                                   const InputVec& u, const InputVec& u_hover);

}  // namespace rejuv::flight
