// The output driver (§IV-B, §IV-C; docs/design.md §2: driver level, never rolled back): holds the mixer as read-only
// data, applies the actuator limits of the current mode (Ū in MC, U otherwise) and turns u = [F, τφ, τθ, τψ]
// into rotor levels U ∈ [0, 1]⁴ through the inverse mixer. Between two publications it holds the last
// controls, which is what the plant sees during RB and CP (§II, §VI-B).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "rejuv/core/time.hpp"
#include "rejuv/flight/limits.hpp"

namespace rejuv::flight {

enum class LimitSet : std::uint8_t { Full, Restricted };

class OutputDriver {
 public:
  OutputDriver(const Eigen::Matrix4d& mixer_inverse, const InputBox& full, const InputBox& restricted,
               const InputVec& initial_u);

  // Only the rejuvenation path sets limits (§IV-C: a message only the output driver can read, sent outside MC).
  void set_limits(LimitSet limits) { limits_ = limits; }
  // The restricted box Ū as the rejuvenation module wrote it (runtime: read through the Limits cap).
  void set_restricted(const InputBox& restricted) { restricted_ = restricted; }
  [[nodiscard]] LimitSet limits() const { return limits_; }

  // A new control vector at time t: clamped to the current limits and held until the next one.
  void publish(Nanos t, const InputVec& u);

  [[nodiscard]] const InputVec& applied_u() const { return u_; }
  // Rotor levels for the plant, each clamped to [0, 1].
  [[nodiscard]] const Eigen::Vector4d& motor_command() const { return motors_; }
  // Longest interval between two publications so far (the gaps of Fig. 7).
  [[nodiscard]] Nanos max_gap() const { return max_gap_; }

 private:
  Eigen::Matrix4d mixer_inverse_;
  InputBox full_;
  InputBox restricted_;
  LimitSet limits_ = LimitSet::Full;
  InputVec u_;
  Eigen::Vector4d motors_;
  std::optional<Nanos> last_publish_;
  Nanos max_gap_{0};
};

}  // namespace rejuv::flight
