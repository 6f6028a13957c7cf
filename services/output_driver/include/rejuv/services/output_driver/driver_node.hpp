// The `output_driver` service (paper §IV-B, §IV-C; docs/design.md §2): driver level, `rejuvenate: false`, never
// rolled back. The simulation's output driver (flight::OutputDriver) behind topics: it applies the actuator
// limits of the mode — the restricted limits Ū in MC, the full limits U otherwise — and turns
// u = [F, τφ, τθ, τψ] into rotor levels U ∈ [0, 1]⁴ through the inverse of the §IV-B mixer, which it holds as
// read-only data.
//
// Topics: in actuator_controls (from lqr_control in MC, safety_control in the SEI), sr_mode (the kernel, on
// every transition); out actuator_outputs, one per accepted actuator_controls, stamped with the driver's
// clock (the plant holds the last one, as the simulation holds the driver's output). Non-finite controls are
// refused and the last outputs stay in force: the driver is the last line before the rotors.
// Limits (§IV-C, docs/design.md §3): on entering MC the process reads Ū through its `actuator_limits` Limits cap
// (Read), written by checkpoint_p before set_MC_mode (flight_io::LimitsRecord); the full limits U are the
// vehicle's, read-only data like the mixer. Until a valid record is read, Ū from the graph's
// sr.restricted_limit_fraction (flight_io/params.hpp) stays in force.
#pragma once

#include <cstdint>

#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/output_driver.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::services {

class DriverNode {
 public:
  // `mixer_inverse`: the plant's inverse mixer (plant::Mixer::inverse); `mode`: the mode at start.
  DriverNode(const Eigen::Matrix4d& mixer_inverse, const flight_io::ActuatorLimits& limits, SrMode mode);

  // Ū in MC, U in every other mode; takes effect from the next controls (the held outputs stay as they are).
  void on_mode(SrMode mode);
  // A Limits record read through the cap: a valid restricted record replaces Ū; anything else is refused
  // and Ū stays as it was.
  [[nodiscard]] Result<void, flight_io::InputFailure> on_limits(std::span<const std::byte> record);
  // Clamps to the limits in force, inverts the mixer (each rotor saturated to [0, 1]).
  [[nodiscard]] Result<rejuv_msg_ActuatorOutputs, flight_io::InputFailure> on_controls(
      const rejuv_msg_ActuatorControls& message, Nanos now);

  [[nodiscard]] const flight::OutputDriver& driver() const { return driver_; }
  [[nodiscard]] flight::LimitSet limits() const { return driver_.limits(); }

 private:
  flight::OutputDriver driver_;
};

// The limit set of a mode (§III, §IV-C: Ū only while the network is on).
[[nodiscard]] flight::LimitSet limits_in(SrMode mode);

}  // namespace rejuv::services
