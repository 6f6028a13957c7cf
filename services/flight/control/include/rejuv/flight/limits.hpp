// Actuator limits of the SR scheme (§III "Limits on Control Uncertainty", §IV-C): the full limits U used by
// the safety controller, and the restricted box Ū ⊂ U that the output driver enforces in MC so that an
// attacker can only use Ū. Both are boxes in u = [F, τφ, τθ, τψ].
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "rejuv/core/result.hpp"
#include "rejuv/flight/hover_model.hpp"

namespace rejuv::flight {

// lo ≤ u ≤ hi componentwise.
struct InputBox {
  InputVec lo = InputVec::Zero();
  InputVec hi = InputVec::Zero();

  [[nodiscard]] InputVec clamp(const InputVec& u) const { return u.cwiseMax(lo).cwiseMin(hi); }
  [[nodiscard]] bool contains(const InputVec& u, double tolerance = 0.0) const;
  // The 2⁴ corners; bit j of the index selects hi (1) or lo (0) for component j.
  [[nodiscard]] std::array<InputVec, 16> corners() const;
};

enum class LimitsError : std::uint8_t {
  BadFraction,        // restricted_limit_fraction not in (0, 1]
  NotMotorFeasible,   // a corner of Ū needs a rotor level outside [0, 1]
};
struct LimitsFailure {
  LimitsError kind;
  std::string message;
};

// U: what the four rotors can produce at most on each axis alone: F ∈ [0, 4 k1], τφ, τθ ∈ [−L k1, L k1],
// τψ ∈ [−2 k2, 2 k2] (from the mixer of §IV-B with U_i ∈ [0, 1]). The output stage still clamps each rotor to
// [0, 1], so a corner of U is not always reachable; U bounds what the safety controller may ask for.
[[nodiscard]] InputBox full_limits(const VehicleParams& params);

// Ū: on every axis, the fraction f of the way from hover to each full limit:
// [u_h − f (u_h − lo), u_h + f (hi − u_h)]. Checked to be reachable by the rotors at every corner, so that
// in MC the output driver's clamp to Ū is exact and the attack corner is really applied.
[[nodiscard]] Result<InputBox, LimitsFailure> restricted_limits(const VehicleParams& params, double fraction);

}  // namespace rejuv::flight
