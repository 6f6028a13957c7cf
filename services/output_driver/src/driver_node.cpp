#include "rejuv/services/output_driver/driver_node.hpp"

#include <utility>

namespace rejuv::services {

flight::LimitSet limits_in(SrMode mode) {
  switch (mode) {
    case SrMode::MC: return flight::LimitSet::Restricted;
    case SrMode::RB:
    case SrMode::SC:
    case SrMode::Update:
    case SrMode::CP: return flight::LimitSet::Full;
  }
  return flight::LimitSet::Restricted;
}

DriverNode::DriverNode(const Eigen::Matrix4d& mixer_inverse, const flight_io::ActuatorLimits& limits,
                       SrMode mode)
    : driver_(mixer_inverse, limits.full, limits.restricted, limits.u_hover) {
  driver_.set_limits(limits_in(mode));
}

void DriverNode::on_mode(SrMode mode) {
  driver_.set_limits(limits_in(mode));
}

Result<void, flight_io::InputFailure> DriverNode::on_limits(std::span<const std::byte> record) {
  auto decoded = flight_io::limits_from_bytes(record);
  if (!decoded) return fail(std::move(decoded.error()));
  if (decoded->set != flight::LimitSet::Restricted) {
    return fail(flight_io::InputFailure{.kind = flight_io::InputError::OutOfRange, .where = "actuator_limits",
                                        .message = "the record holds the full limits U, not the restricted Ū"});
  }
  driver_.set_restricted(decoded->box);
  return {};
}

Result<rejuv_msg_ActuatorOutputs, flight_io::InputFailure> DriverNode::on_controls(
    const rejuv_msg_ActuatorControls& message, Nanos now) {
  auto u = flight_io::controls_from_message(message);
  if (!u) return fail(std::move(u.error()));
  driver_.publish(now, *u);
  rejuv_msg_ActuatorOutputs out{};
  out.timestamp_ns = flight_io::stamp(now);
  const Eigen::Vector4d& U = driver_.motor_command();
  for (Eigen::Index i = 0; i < 4; ++i) out.motor[i] = U[i];
  out.limits_restricted = driver_.limits() == flight::LimitSet::Restricted ? 1 : 0;
  return out;
}

}  // namespace rejuv::services
