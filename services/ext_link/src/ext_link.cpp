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
  return Forward{.upload = to_message(*upload, now), .decoded = *upload, .sequence = message->sequence};
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
