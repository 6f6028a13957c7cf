#include "rejuv/services/ext_link/ext_link.hpp"

namespace rejuv::services {

rejuv_msg_MissionWaypoints to_message(const link::MissionUpload& upload, Nanos now) {
  rejuv_msg_MissionWaypoints m{};
  m.timestamp_ns = static_cast<std::uint64_t>(now.count());
  m.count = upload.count;
  for (std::uint32_t i = 0; i < upload.count && i < link::kMaxUploadWaypoints; ++i) {
    const link::UploadWaypoint& w = upload.waypoints[i];
    m.waypoints[i].p_N_m[0] = w.north_m;
    m.waypoints[i].p_N_m[1] = w.east_m;
    m.waypoints[i].p_N_m[2] = w.down_m;
    m.waypoints[i].yaw_rad = w.yaw_rad;
  }
  m.acceptance_radius_m = upload.acceptance_radius_m;
  return m;
}

Result<ExtLink, flight_io::InputFailure> ExtLink::from_params(const flight_io::Params& params) {
  auto mission = flight_io::mission_params(params);
  if (!mission) return fail(std::move(mission.error()));
  auto bounds = flight_io::upload_bounds(params);
  if (!bounds) return fail(std::move(bounds.error()));
  return ExtLink(UploadGuard{.home = mission->waypoints.front(), .bounds = *bounds});
}

namespace {

link::RefusalReason reason_of(flight_io::UploadCheck check) {
  switch (check) {
    case flight_io::UploadCheck::TooManyWaypoints: return link::RefusalReason::TooManyWaypoints;
    case flight_io::UploadCheck::OutsideGeofence: return link::RefusalReason::OutsideGeofence;
    case flight_io::UploadCheck::BelowAltitudeFloor: return link::RefusalReason::BelowAltitudeFloor;
    case flight_io::UploadCheck::Accepted:  // not a refusal: never here
    case flight_io::UploadCheck::Invalid: return link::RefusalReason::InvalidMission;
  }
  return link::RefusalReason::InvalidMission;
}

}  // namespace

Result<ExtLink::Inbound, link::DecodeError> ExtLink::on_datagram(std::span<const std::byte> datagram, Nanos now) {
  auto message = link::decode(datagram, link::Direction::ToVehicle);
  if (!message) {
    ++refused_total_;
    ++refused_[static_cast<std::size_t>(message.error())];
    return fail(message.error());
  }
  if (std::holds_alternative<link::Hello>(message->body)) {
    ground_known_ = true;
    return GroundHello{};
  }
  const auto* upload = std::get_if<link::MissionUpload>(&message->body);
  REJUV_ASSERT(upload != nullptr, "decode(ToVehicle) yields only Hello and MissionUpload");
  ground_known_ = true;
  if (last_upload_ && *last_upload_ == *upload && last_upload_sequence_ == message->sequence) {
    return Reacknowledge{.sequence = message->sequence};
  }
  rejuv_msg_MissionWaypoints forward = to_message(*upload, now);
  // The check commander applies, so that the ground station learns the verdict (docs/link_protocol.md).
  if (auto valid = flight_io::validate_upload(forward, guard_.home, guard_.bounds); !valid) {
    const std::size_t at = valid.error().waypoint < link::kMaxUploadWaypoints ? valid.error().waypoint : 0;
    return Refuse{.sequence = message->sequence,
                  .reason = reason_of(valid.error().check),
                  .waypoint = static_cast<std::uint16_t>(at),
                  .message = valid.error().message};
  }
  return Forward{.upload = forward, .decoded = *upload, .sequence = message->sequence};
}

link::Datagram ExtLink::refused_upload(const Refuse& refuse) {
  ++uploads_refused_;
  return link::encode(link::Message{.sequence = next_sequence_++,
                                    .body = link::MissionAck{.upload_sequence = refuse.sequence,
                                                             .status = link::AckStatus::Refused,
                                                             .reason = refuse.reason,
                                                             .waypoint = refuse.waypoint}});
}

link::Datagram ExtLink::forwarded(const Forward& forward) {
  ++uploads_forwarded_;
  last_upload_ = forward.decoded;
  last_upload_sequence_ = forward.sequence;
  return acknowledge(forward.sequence);
}

link::Datagram ExtLink::acknowledge(std::uint32_t upload_sequence) {
  return link::encode(link::Message{
      .sequence = next_sequence_++,
      .body = link::MissionAck{.upload_sequence = upload_sequence, .status = link::AckStatus::Forwarded}});
}

link::Datagram ExtLink::telemetry(const TelemetryInputs& in) {
  link::Telemetry t;
  t.time_ns = static_cast<std::uint64_t>(in.now.count());
  if (in.state != nullptr) {
    for (std::size_t i = 0; i < 3; ++i) {
      t.p_N_m[i] = in.state->p_N_m[i];
      t.v_N_m_s[i] = in.state->v_N_m_s[i];
    }
  }
  if (in.setpoint != nullptr) {
    for (std::size_t i = 0; i < 3; ++i) t.setpoint_N_m[i] = in.setpoint->p_N_m[i];
    t.setpoint_yaw_rad = in.setpoint->yaw_rad;
    t.waypoint_index = in.setpoint->waypoint_index;
    t.mission_done = in.setpoint->mission_done != 0 ? 1 : 0;
  }
  t.sr_mode = static_cast<std::uint8_t>(index_of(in.mode));
  t.epoch = static_cast<std::uint32_t>(in.epoch.value());
  t.security_events = in.security_events;
  t.link_refused = refused_total_;
  t.uploads_forwarded = uploads_forwarded_;
  return link::encode(link::Message{.sequence = next_sequence_++, .body = t});
}

bool ExtLink::should_log_refusal(Nanos now, std::uint64_t& suppressed) {
  if (last_log_ && now - *last_log_ < std::chrono::seconds{1}) {
    ++unlogged_;
    return false;
  }
  last_log_ = now;
  suppressed = unlogged_;
  unlogged_ = 0;
  return true;
}

}  // namespace rejuv::services
