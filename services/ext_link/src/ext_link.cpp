#include "rejuv/services/ext_link/ext_link.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rejuv::services {

namespace mav = rejuv::mavlink;

std::uint32_t custom_mode_of(SrMode mode, Epoch epoch) {
  return static_cast<std::uint32_t>(index_of(mode)) | (static_cast<std::uint32_t>(epoch.value() & 0xFF'FFFFU) << 8U);
}

rejuv_msg_MissionWaypoints to_message(std::span<const mav::LocalWaypoint> waypoints, double acceptance_radius_m, Nanos now) {
  rejuv_msg_MissionWaypoints m{};
  m.timestamp_ns = static_cast<std::uint64_t>(now.count());
  m.count = static_cast<std::uint32_t>(std::min(waypoints.size(), kMaxUploadWaypoints));
  for (std::size_t i = 0; i < m.count; ++i) {
    m.waypoints[i].p_N_m[0] = waypoints[i].north_m;
    m.waypoints[i].p_N_m[1] = waypoints[i].east_m;
    m.waypoints[i].p_N_m[2] = waypoints[i].down_m;
    m.waypoints[i].yaw_rad = waypoints[i].yaw_rad;
  }
  m.acceptance_radius_m = acceptance_radius_m;
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

// commander's verdict as the mission protocol's error code (docs/mavlink.md "Mission upload").
mav::MissionResult result_of(flight_io::UploadCheck check) {
  switch (check) {
    case flight_io::UploadCheck::TooManyWaypoints: return mav::MissionResult::NoSpace;
    case flight_io::UploadCheck::OutsideGeofence: return mav::MissionResult::InvalidParam5X;
    case flight_io::UploadCheck::BelowAltitudeFloor: return mav::MissionResult::InvalidParam7;
    case flight_io::UploadCheck::Accepted:  // not a refusal: never here
    case flight_io::UploadCheck::Invalid: return mav::MissionResult::Invalid;
  }
  return mav::MissionResult::Invalid;
}

bool for_this_vehicle(std::uint8_t target_system) { return target_system == kVehicleSystem || target_system == 0; }

mav::Severity severity_of(rejuv_msg_SecurityEventKind kind) {
  switch (kind) {
    case rejuv_msg_SECURITY_CAPABILITY_DENIAL: return mav::Severity::Warning;
    case rejuv_msg_SECURITY_FORBIDDEN_CALL: return mav::Severity::Critical;
    case rejuv_msg_SECURITY_STRAY_PROCESS: return mav::Severity::Critical;
    case rejuv_msg_SECURITY_IMAGE_LOST: return mav::Severity::Alert;
    case rejuv_msg_SECURITY_OUT_OF_MEMORY: return mav::Severity::Critical;
    case rejuv_msg_SECURITY_PUBLICATION_BUDGET: return mav::Severity::Warning;
  }
  return mav::Severity::Warning;
}

const char* name_of(rejuv_msg_SecurityEventKind kind) {
  switch (kind) {
    case rejuv_msg_SECURITY_CAPABILITY_DENIAL: return "capability denial";
    case rejuv_msg_SECURITY_FORBIDDEN_CALL: return "forbidden call";
    case rejuv_msg_SECURITY_STRAY_PROCESS: return "stray process";
    case rejuv_msg_SECURITY_IMAGE_LOST: return "image lost";
    case rejuv_msg_SECURITY_OUT_OF_MEMORY: return "out of memory";
    case rejuv_msg_SECURITY_PUBLICATION_BUDGET: return "publications over budget";
  }
  return "?";
}

// The estimate on Earth: home plus the local NED offset on a sphere of the WGS-84 equatorial radius (the
// flat-Earth approximation PX4's map_projection uses near home; the geofence keeps the vehicle within metres).
mav::GlobalPositionInt global_position(const ExtLink::GeoHome& home, const rejuv_msg_VehicleStateEstimate& s,
                                       double yaw_rad, std::uint32_t time_boot_ms) {
  constexpr double kEarthRadius_m = 6'378'137.0;
  constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;
  const double lat_deg = home.lat_deg + s.p_N_m[0] / kEarthRadius_m * kDegPerRad;
  const double lon_deg = home.lon_deg + s.p_N_m[1] / (kEarthRadius_m * std::cos(home.lat_deg / kDegPerRad)) * kDegPerRad;
  const auto i32 = [](double v) {
    return static_cast<std::int32_t>(std::clamp(std::round(v), -2147483648.0, 2147483647.0));
  };
  const auto i16 = [](double v) { return static_cast<std::int16_t>(std::clamp(std::round(v), -32768.0, 32767.0)); };
  double heading_deg = std::fmod(yaw_rad * kDegPerRad + 360.0, 360.0);
  if (!std::isfinite(heading_deg)) heading_deg = 0;
  return mav::GlobalPositionInt{.time_boot_ms = time_boot_ms,
                                .lat = i32(lat_deg * 1e7),
                                .lon = i32(lon_deg * 1e7),
                                .alt = i32((home.alt_m - s.p_N_m[2]) * 1e3),  // [mm] AMSL; NED down is −up
                                .relative_alt = i32(-s.p_N_m[2] * 1e3),      // [mm] above home
                                .vx = i16(s.v_N_m_s[0] * 100),               // [cm/s] north
                                .vy = i16(s.v_N_m_s[1] * 100),               // [cm/s] east
                                .vz = i16(s.v_N_m_s[2] * 100),               // [cm/s] down
                                .hdg = static_cast<std::uint16_t>(std::min(35999.0, std::round(heading_deg * 100)))};
}

}  // namespace

mav::Message ExtLink::ack(std::uint8_t system, std::uint8_t component, mav::MissionResult result) const {
  return mav::MissionAck{.target_system = system,
                         .target_component = component,
                         .type = static_cast<std::uint8_t>(result),
                         .mission_type = mav::kMissionTypeMission,
                         .opaque_id = 0};
}

Result<ExtLink::Inbound, mav::DecodeError> ExtLink::on_datagram(std::span<const std::byte> datagram, Nanos now) {
  auto packet = mav::decode(datagram);
  if (!packet) {
    ++refused_total_;
    ++refused_[static_cast<std::size_t>(packet.error())];
    return fail(packet.error());
  }
  const mav::FrameHeader& from = packet->header;
  if (const auto* count = std::get_if<mav::MissionCount>(&packet->message)) {
    if (!for_this_vehicle(count->target_system)) return Inbound{};
    return on_count(from, *count);
  }
  if (const auto* item = std::get_if<mav::MissionItemInt>(&packet->message)) {
    if (!for_this_vehicle(item->target_system)) return Inbound{};
    return on_item(from, *item, now);
  }
  if (const auto* list = std::get_if<mav::MissionRequestList>(&packet->message)) {
    if (!for_this_vehicle(list->target_system) || list->mission_type != mav::kMissionTypeMission) return Inbound{};
    return Inbound{.replies = {mav::MissionCount{.count = 0, .target_system = from.sysid, .target_component = from.compid,
                                                 .mission_type = mav::kMissionTypeMission, .opaque_id = 0}}};
  }
  if (const auto* clear = std::get_if<mav::MissionClearAll>(&packet->message)) {
    if (!for_this_vehicle(clear->target_system)) return Inbound{};
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Unsupported)},
                   .note = "MISSION_CLEAR_ALL refused: an uploaded mission can only be replaced"};
  }
  return Inbound{};  // HEARTBEAT and the rest: valid (the sender is the ground station), nothing to answer
}

ExtLink::Inbound ExtLink::on_count(const mav::FrameHeader& from, const mav::MissionCount& count) {
  if (count.mission_type != mav::kMissionTypeMission) {
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Unsupported)}};
  }
  if (count.count == 0) {
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Unsupported)},
                   .note = "an empty mission (a clear) is not accepted: an uploaded mission can only be replaced"};
  }
  if (count.count > kMaxUploadWaypoints) {
    ++uploads_refused_;
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::NoSpace)}};
  }
  // A new MISSION_COUNT starts the upload again (also one in progress: the ground station restarted).
  receiving_ = Receiving{.count = count.count, .ground_system = from.sysid, .ground_component = from.compid,
                         .acceptance_radius_m = kDefaultAcceptanceRadius_m, .waypoints = {}};
  return Inbound{.replies = {mav::MissionRequestInt{.seq = 0, .target_system = from.sysid, .target_component = from.compid,
                                                    .mission_type = mav::kMissionTypeMission}}};
}

ExtLink::Inbound ExtLink::on_item(const mav::FrameHeader& from, const mav::MissionItemInt& item, Nanos now) {
  if (item.mission_type != mav::kMissionTypeMission) return Inbound{};
  if (!receiving_) {
    // The last item again after the ack (lost on the way): acknowledge again, publish nothing.
    if (last_forwarded_ && item.seq + 1U == last_forwarded_->size() &&
        mav::waypoint_of(item) == last_forwarded_->back()) {
      return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Accepted)}};
    }
    // No upload in progress (a rollback ended the one this belonged to): the ground station starts again.
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::InvalidSequence)}};
  }
  Receiving& r = *receiving_;
  const std::size_t expected = r.waypoints.size();
  if (item.seq != expected) {
    // A duplicate or one ahead: ask again for the one expected (spec: the vehicle re-requests).
    return Inbound{.replies = {mav::MissionRequestInt{.seq = static_cast<std::uint16_t>(expected), .target_system = from.sysid,
                                                      .target_component = from.compid,
                                                      .mission_type = mav::kMissionTypeMission}}};
  }
  const auto refuse = [&](mav::MissionResult result, std::string why) {
    receiving_.reset();
    ++uploads_refused_;
    return Inbound{.replies = {ack(from.sysid, from.compid, result)}, .forward = std::nullopt, .note = std::move(why)};
  };
  if (item.frame != mav::kMavFrameLocalNed) {
    return refuse(mav::MissionResult::UnsupportedFrame, "item " + std::to_string(item.seq) + ": frame " +
                                                            std::to_string(item.frame) + " (only MAV_FRAME_LOCAL_NED)");
  }
  if (item.command != mav::kMavCmdNavWaypoint) {
    return refuse(mav::MissionResult::Unsupported, "item " + std::to_string(item.seq) + ": command " +
                                                       std::to_string(item.command) + " (only MAV_CMD_NAV_WAYPOINT)");
  }
  if (!std::isfinite(item.z)) return refuse(mav::MissionResult::InvalidParam7, "item " + std::to_string(item.seq) + ": z not finite");
  if (!std::isfinite(item.param2) || item.param2 < 0) {
    return refuse(mav::MissionResult::InvalidParam2, "item " + std::to_string(item.seq) + ": acceptance radius");
  }
  // The mission's one acceptance radius: the first item's (0: the default).
  if (item.seq == 0 && item.param2 > 0) r.acceptance_radius_m = item.param2;
  r.waypoints.push_back(mav::waypoint_of(item));
  if (r.waypoints.size() < r.count) {
    return Inbound{.replies = {mav::MissionRequestInt{.seq = static_cast<std::uint16_t>(r.waypoints.size()),
                                                      .target_system = from.sysid, .target_component = from.compid,
                                                      .mission_type = mav::kMissionTypeMission}}};
  }
  // Complete: judged as commander will judge it.
  Receiving done = std::move(r);
  receiving_.reset();
  rejuv_msg_MissionWaypoints forward = to_message(done.waypoints, done.acceptance_radius_m, now);
  if (auto valid = flight_io::validate_upload(forward, guard_.home, guard_.bounds); !valid) {
    ++uploads_refused_;
    const std::size_t at = valid.error().waypoint;
    // The reason first (a ground station prints it with the ack that ends the transaction).
    return Inbound{.replies = {mav::status_text(mav::Severity::Warning,
                                                "mission refused: " + std::string(flight_io::to_string(valid.error().check)) +
                                                    " (item " + std::to_string(at) + ")"),
                               ack(done.ground_system, done.ground_component, result_of(valid.error().check))},
                   .forward = std::nullopt,
                   .note = "mission upload refused: " + valid.error().message};
  }
  if (last_forwarded_ && *last_forwarded_ == done.waypoints) {
    // The mission just forwarded, uploaded again: acknowledged, not republished.
    return Inbound{.replies = {ack(done.ground_system, done.ground_component, mav::MissionResult::Accepted)}};
  }
  return Inbound{.replies = {},
                 .forward = Forward{.upload = forward, .waypoints = std::move(done.waypoints),
                                    .ground_system = done.ground_system, .ground_component = done.ground_component},
                 .note = std::nullopt};
}

mav::Message ExtLink::forwarded(const Forward& forward) {
  ++uploads_forwarded_;
  last_forwarded_ = forward.waypoints;
  return ack(forward.ground_system, forward.ground_component, mav::MissionResult::Accepted);
}

void ExtLink::abandon() { receiving_.reset(); }

mav::Frame ExtLink::frame(const mav::Message& message) {
  return mav::encode(message, mav::Envelope{.seq = next_seq_++, .sysid = kVehicleSystem, .compid = kVehicleComponent});
}

void ExtLink::queue_text(Epoch epoch, mav::Severity severity, const std::string& text) {
  if (pending_.size() == kMaxPendingTexts) pending_.pop_front();
  pending_.push_back(PendingText{.epoch = epoch, .text = mav::status_text(severity, text)});
}

void ExtLink::observe(const Observation& seen) {
  if (seen_epoch_ && seen.epoch != *seen_epoch_) {
    std::erase_if(pending_, [&](const PendingText& p) { return p.epoch.value() < seen.epoch.value(); });
    queue_text(seen.epoch, mav::Severity::Notice,
               "SR rollback: epoch " + std::to_string(seen.epoch.value()) + " (last checkpoint restored)");
  }
  if (seen_mode_ && seen.mode != *seen_mode_) {
    queue_text(seen.epoch, mav::Severity::Info, "SR mode " + std::string(to_string(seen.mode)));
  }
  if (seen.security_events > seen_events_ && seen_mode_) {
    char line[96];
    if (seen.latest_event != nullptr) {
      // At most 50 characters (STATUSTEXT): the latest event's kind and service, and how many are new.
      std::snprintf(line, sizeof line, "security: %s, service %u, %llu new", name_of(seen.latest_event->kind),
                    seen.latest_event->service_id, static_cast<unsigned long long>(seen.security_events - seen_events_));
    } else {
      std::snprintf(line, sizeof line, "security: %llu new event(s)", static_cast<unsigned long long>(seen.security_events - seen_events_));
    }
    queue_text(seen.epoch, seen.latest_event != nullptr ? severity_of(seen.latest_event->kind) : mav::Severity::Warning, line);
  }
  seen_epoch_ = seen.epoch;
  seen_mode_ = seen.mode;
  seen_events_ = std::max(seen_events_, seen.security_events);
}

std::vector<mav::Message> ExtLink::telemetry(const TelemetryInputs& in) {
  std::vector<mav::Message> out;
  while (!pending_.empty()) {
    out.emplace_back(pending_.front().text);
    pending_.pop_front();
  }
  const auto time_boot_ms = static_cast<std::uint32_t>(in.now.count() / 1'000'000);
  if (!last_slow_ || in.now - *last_slow_ >= std::chrono::seconds{1}) {
    last_slow_ = in.now;
    out.emplace_back(mav::Heartbeat{.custom_mode = custom_mode_of(in.mode, in.epoch),
                                    .type = mav::kMavTypeQuadrotor,
                                    .autopilot = mav::kMavAutopilotGeneric,
                                    .base_mode = static_cast<std::uint8_t>(mav::kModeFlagCustomModeEnabled |
                                                                           mav::kModeFlagAutoEnabled |
                                                                           mav::kModeFlagSafetyArmed),
                                    .system_status = mav::kMavStateActive,
                                    .mavlink_version = 3});
    mav::SysStatus sys{};
    sys.battery_remaining = -1;
    sys.current_battery = -1;
    sys.voltage_battery = 0xFFFF;
    out.emplace_back(sys);
    if (in.setpoint != nullptr) {
      out.emplace_back(mav::MissionCurrent{.seq = static_cast<std::uint16_t>(in.setpoint->waypoint_index),
                                           .total = 0, .mission_state = 0, .mission_mode = 0, .mission_id = 0,
                                           .fence_id = 0, .rally_points_id = 0});
    }
  }
  // The setpoint moved on to the next waypoint: the one before is reached (mission protocol "Mission
  // progress"). A rollback may restore an older index; the one reached is then reported again.
  if (in.setpoint != nullptr) {
    if (last_waypoint_ && in.setpoint->waypoint_index > *last_waypoint_) {
      out.emplace_back(mav::MissionItemReached{.seq = static_cast<std::uint16_t>(in.setpoint->waypoint_index - 1)});
    }
    last_waypoint_ = in.setpoint->waypoint_index;
  }
  if (in.state != nullptr) {
    const rejuv_msg_VehicleStateEstimate& s = *in.state;
    out.emplace_back(mav::LocalPositionNed{.time_boot_ms = time_boot_ms,
                                           .x = static_cast<float>(s.p_N_m[0]),
                                           .y = static_cast<float>(s.p_N_m[1]),
                                           .z = static_cast<float>(s.p_N_m[2]),
                                           .vx = static_cast<float>(s.v_N_m_s[0]),
                                           .vy = static_cast<float>(s.v_N_m_s[1]),
                                           .vz = static_cast<float>(s.v_N_m_s[2])});
    // q_NB = (w, x, y, z), body to NED: Tait–Bryan ZYX angles.
    const double w = s.q_NB[0], x = s.q_NB[1], y = s.q_NB[2], z = s.q_NB[3];
    const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
    const double pitch = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
    const double yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
    if (home_) out.emplace_back(global_position(*home_, s, yaw, time_boot_ms));
    out.emplace_back(mav::Attitude{.time_boot_ms = time_boot_ms,
                                   .roll = static_cast<float>(roll),
                                   .pitch = static_cast<float>(pitch),
                                   .yaw = static_cast<float>(yaw),
                                   .rollspeed = static_cast<float>(s.omega_B_rad_s[0]),
                                   .pitchspeed = static_cast<float>(s.omega_B_rad_s[1]),
                                   .yawspeed = static_cast<float>(s.omega_B_rad_s[2])});
  }
  return out;
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
