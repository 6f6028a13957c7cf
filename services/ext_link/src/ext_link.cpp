#include "rejuv/services/ext_link/ext_link.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "rejuv/core/graph_values.hpp"

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
  ExtLink link(UploadGuard{.home = mission->waypoints.front(), .bounds = *bounds}, *mission);
  if (auto sr = link.set_sr_values(params); !sr) return fail(std::move(sr.error()));
  return link;
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

// GPS_RAW_INT of a GPS sample (in the local frame: idl/sensors.idl) on Earth against home.
mav::GpsRawInt gps_raw(const ExtLink::GeoHome& home, const rejuv_msg_SensorGps& gps) {
  const mav::GeoPoint p = mav::global_of(home, gps.p_N_m[0], gps.p_N_m[1], gps.p_N_m[2]);
  const double speed_m_s = std::hypot(gps.v_N_m_s[0], gps.v_N_m_s[1]);
  double cog_deg = std::fmod(std::atan2(gps.v_N_m_s[1], gps.v_N_m_s[0]) * 180.0 / std::numbers::pi + 360.0, 360.0);
  if (!std::isfinite(cog_deg)) cog_deg = 0;
  const auto u32 = [](double v) { return static_cast<std::uint32_t>(std::clamp(std::round(v), 0.0, 4294967295.0)); };
  mav::GpsRawInt r{};
  r.time_usec = gps.timestamp_ns / 1000U;
  r.lat = static_cast<std::int32_t>(std::lround(p.lat_deg * 1e7));
  r.lon = static_cast<std::int32_t>(std::lround(p.lon_deg * 1e7));
  r.alt = static_cast<std::int32_t>(std::lround(p.alt_m * 1e3));  // [mm] AMSL
  r.eph = 0xFFFF;  // HDOP, DOP: not modelled (the accuracies are in h_acc, v_acc)
  r.epv = 0xFFFF;
  r.vel = static_cast<std::uint16_t>(std::min(65534.0, std::round(speed_m_s * 100)));  // [cm/s]
  r.cog = speed_m_s > 0.1 ? static_cast<std::uint16_t>(std::min(35999.0, std::round(cog_deg * 100))) : 0xFFFF;  // [cdeg]
  r.fix_type = gps.fix_type;  // GPS_FIX_TYPE: 0 none, 2 2D, 3 3D (the sample's own codes)
  r.satellites_visible = gps.satellites_used;
  r.alt_ellipsoid = 0;
  r.h_acc = u32(gps.eph_m * 1e3);  // [mm]
  r.v_acc = u32(gps.epv_m * 1e3);  // [mm]
  r.vel_acc = 0;
  r.hdg_acc = 0;
  r.yaw = 0;  // no dual-antenna heading
  return r;
}

}  // namespace

mav::Message ExtLink::ack(std::uint8_t system, std::uint8_t component, mav::MissionResult result,
                          std::uint8_t mission_type) const {
  return mav::MissionAck{.target_system = system,
                         .target_component = component,
                         .type = static_cast<std::uint8_t>(result),
                         .mission_type = mission_type,
                         .opaque_id = 0};
}

namespace {

mav::LocalWaypoint local_of(const flight::PathWaypoint& w) {
  return mav::LocalWaypoint{.north_m = w.p_N_m.x(), .east_m = w.p_N_m.y(), .down_m = w.p_N_m.z(), .yaw_rad = w.yaw_rad};
}

std::vector<mav::LocalWaypoint> local_of(const flight_io::MissionSpec& mission) {
  std::vector<mav::LocalWaypoint> out;
  for (const flight::PathWaypoint& w : mission.waypoints) out.push_back(local_of(w));
  return out;
}

constexpr std::uint16_t kCmdReturnToLaunch = 20;  // MAV_CMD_NAV_RETURN_TO_LAUNCH

// MAV_RESULT (COMMAND_ACK.result).
constexpr std::uint8_t kResultAccepted = 0;
constexpr std::uint8_t kResultDenied = 2;
constexpr std::uint8_t kResultUnsupported = 3;
constexpr std::uint8_t kResultFailed = 4;

mav::CommandAck command_ack(const mav::FrameHeader& to, std::uint16_t command, std::uint8_t result) {
  return mav::CommandAck{.command = command, .result = result, .progress = 0, .result_param2 = 0,
                         .target_system = to.sysid, .target_component = to.compid};
}

bool for_this_component(std::uint8_t target_component) {
  return target_component == kVehicleComponent || target_component == 0;
}

std::array<char, 16> param_id_of(std::string_view name) {
  std::array<char, 16> id{};
  std::copy_n(name.begin(), std::min(name.size(), id.size()), id.begin());
  return id;
}

std::string name_of(const std::array<char, 16>& id) {
  return std::string(id.begin(), std::find(id.begin(), id.end(), '\0'));
}

namespace gv = rejuv::graph_values;

// The SR scheme's graph-wide keys the ground sees (docs/mavlink.md "Parameters"), each under an RJ_SR_ name: the
// cycle (T_MC, T_est, t_min, the check's period), the sets (ρ_M, ρ_s, the box that scales P), the restricted
// controls Ū and the images kept (K). The estimator's re-arm σs are left out: internal to ekf2's restart.
using AnyKey = std::variant<const gv::Key<bool>*, const gv::Key<Nanos>*, const gv::Key<std::uint32_t>*,
                            const gv::Key<double>*>;
struct SrParamName {
  std::string_view name;
  AnyKey key;
};
constexpr std::array<SrParamName, 13> kSrParams{{
    {"RJ_SR_ENABLED", &gv::kEnabled},  // first: alone when SR is off
    {"RJ_SR_T_MC", &gv::kTmc},
    {"RJ_SR_T_EST", &gv::kTest},
    {"RJ_SR_T_MIN", &gv::kTmin},
    {"RJ_SR_CHK_PERIOD", &gv::kCheckPeriod},
    {"RJ_SR_RHO_M", &gv::kRhoM},
    {"RJ_SR_RHO_S", &gv::kRhoS},
    {"RJ_SR_U_RESTR", &gv::kRestrictedLimitFraction},
    {"RJ_SR_KEEP_GEN", &gv::kKeepGenerations},
    {"RJ_SR_BOX_POS", &gv::kBoxPosition},
    {"RJ_SR_BOX_VEL", &gv::kBoxVelocity},
    {"RJ_SR_BOX_ANG", &gv::kBoxAngle},
    {"RJ_SR_BOX_RATE", &gv::kBoxRate},
}};
static_assert(std::ranges::all_of(kSrParams, [](const SrParamName& p) { return p.name.size() <= 16; }),
              "PARAM_VALUE.param_id holds 16 characters");

// A key's value as a param's: a switch and a count as INT32, a duration in seconds, the rest in their unit.
std::variant<float, std::int32_t> param_of(bool on) { return std::int32_t{on ? 1 : 0}; }
std::variant<float, std::int32_t> param_of(Nanos t) { return static_cast<float>(to_seconds(t).count()); }
std::variant<float, std::int32_t> param_of(std::uint32_t n) { return static_cast<std::int32_t>(n); }
std::variant<float, std::int32_t> param_of(double v) { return static_cast<float>(v); }

}  // namespace

std::uint8_t ExtLink::Param::type() const {
  constexpr std::uint8_t kReal32 = 9, kInt32 = 6;  // MAV_PARAM_TYPE
  return std::holds_alternative<std::int32_t>(value) ? kInt32 : kReal32;
}

float ExtLink::Param::wire_value() const {
  return std::visit([](auto v) { return std::bit_cast<float>(v); }, value);
}

Result<void, flight_io::InputFailure> ExtLink::set_sr_values(const flight_io::Params& params) {
  auto enabled = flight_io::read(params, gv::kEnabled);
  if (!enabled) return fail(std::move(enabled.error()));
  if (!*enabled) {
    // A run without SR: the scheme's other values act on nothing (a graph without an `sr` block passes zeros).
    sr_params_ = {Param{.name = std::string(kSrParams.front().name), .value = param_of(false)}};
    rebuild_params();
    return {};
  }
  std::vector<Param> listed;
  for (const SrParamName& p : kSrParams) {
    auto value = std::visit(
        [&](const auto* key) -> Result<std::variant<float, std::int32_t>, flight_io::InputFailure> {
          auto v = flight_io::read(params, *key);
          if (!v) return fail(std::move(v.error()));
          return param_of(*v);
        },
        p.key);
    if (!value) return fail(std::move(value.error()));
    listed.push_back(Param{.name = std::string(p.name), .value = *value});
  }
  sr_params_ = std::move(listed);
  rebuild_params();
  return {};
}

void ExtLink::set_telemetry_period(double period_s) {
  telemetry_period_s_ = period_s;
  rebuild_params();
}

void ExtLink::rebuild_params() {
  // docs/mavlink.md "Parameters": PX4's name where PX4 has the same quantity, RJ_ otherwise.
  params_ = {
      Param{.name = "NAV_ACC_RAD", .value = static_cast<float>(launch_mission_.acceptance_radius_m)},
      Param{.name = "GF_MAX_HOR_DIST", .value = static_cast<float>(guard_.bounds.geofence_radius_m)},
      Param{.name = "RJ_GF_MIN_ALT", .value = static_cast<float>(guard_.bounds.min_altitude_m)},
      Param{.name = "RJ_TLM_PERIOD", .value = static_cast<float>(telemetry_period_s_)},
  };
  if (home_) {
    params_.push_back(Param{.name = "RJ_HOME_LAT", .value = static_cast<float>(home_->lat_deg)});
    params_.push_back(Param{.name = "RJ_HOME_LON", .value = static_cast<float>(home_->lon_deg)});
    params_.push_back(Param{.name = "RJ_HOME_ALT", .value = static_cast<float>(home_->alt_m)});
  }
  params_.insert(params_.end(), sr_params_.begin(), sr_params_.end());
}

mav::ParamValue ExtLink::param_value(std::size_t index) const {
  const Param& p = params_[index];
  return mav::ParamValue{.param_value = p.wire_value(),
                         .param_count = static_cast<std::uint16_t>(params_.size()),
                         .param_index = static_cast<std::uint16_t>(index),
                         .param_id = param_id_of(p.name),
                         .param_type = p.type()};
}

ExtLink::Flown ExtLink::flown() const {
  if (last_forwarded_) {
    return Flown{.waypoints = *last_forwarded_, .acceptance_radius_m = last_forwarded_radius_m_.value_or(kDefaultAcceptanceRadius_m),
                 .index_offset = 1};
  }
  if (kept_) return Flown{.waypoints = local_of(*kept_), .acceptance_radius_m = kept_->acceptance_radius_m, .index_offset = 1};
  return Flown{.waypoints = local_of(launch_mission_), .acceptance_radius_m = launch_mission_.acceptance_radius_m,
               .index_offset = 0};
}

mav::Message ExtLink::home_position(std::uint32_t time_boot_ms) const {
  mav::HomePosition h{};
  if (home_) {
    // Home is the local frame's origin; the launch mission starts there (x, y, z: its position in NED).
    h.latitude = static_cast<std::int32_t>(std::lround(home_->lat_deg * mav::kGlobalIntScale));
    h.longitude = static_cast<std::int32_t>(std::lround(home_->lon_deg * mav::kGlobalIntScale));
    h.altitude = static_cast<std::int32_t>(std::lround(home_->alt_m * 1e3));  // [mm] AMSL
  }
  h.q = {1, 0, 0, 0};
  h.time_usec = std::uint64_t{time_boot_ms} * 1000U;
  return h;
}

mav::Message ExtLink::autopilot_version() const {
  // MAV_PROTOCOL_CAPABILITY bits of what is answered here: PARAM_FLOAT (2), MISSION_INT (4), COMMAND_INT (8),
  // PARAM_ENCODE_BYTEWISE (16: an INT32 param's bytes in param_value, as PX4), MAVLINK2 (8192). Not MISSION_FLOAT
  // (MISSION_ITEM is not accepted), no fence or rally, no offboard control.
  mav::AutopilotVersion v{};
  v.capabilities = 2U | 4U | 8U | 16U | 8192U;
  v.uid = kVehicleSystem;
  return v;
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
    return on_count(from, *count, now);
  }
  if (const auto* item = std::get_if<mav::MissionItemInt>(&packet->message)) {
    if (!for_this_vehicle(item->target_system)) return Inbound{};
    return on_item(from, *item, now);
  }
  if (const auto* list = std::get_if<mav::MissionRequestList>(&packet->message)) {
    if (!for_this_vehicle(list->target_system)) return Inbound{};
    // Fence and rally points: the vehicle has none (an empty list is the protocol's answer).
    const std::size_t n = list->mission_type == mav::kMissionTypeMission ? flown().waypoints.size() : 0;
    return Inbound{.replies = {mav::MissionCount{.count = static_cast<std::uint16_t>(n), .target_system = from.sysid,
                                                 .target_component = from.compid, .mission_type = list->mission_type,
                                                 .opaque_id = 0}}};
  }
  if (const auto* request = std::get_if<mav::MissionRequestInt>(&packet->message)) {
    if (!for_this_vehicle(request->target_system)) return Inbound{};
    const Flown f = flown();
    if (request->mission_type != mav::kMissionTypeMission || request->seq >= f.waypoints.size()) {
      return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::InvalidSequence, request->mission_type)}};
    }
    const mav::LocalWaypoint& w = f.waypoints[request->seq];
    return Inbound{.replies = {home_ ? mav::global_item(*home_, w, request->seq, f.acceptance_radius_m, from.sysid, from.compid)
                                     : mav::local_item(w, request->seq, f.acceptance_radius_m, from.sysid, from.compid)}};
  }
  if (const auto* clear = std::get_if<mav::MissionClearAll>(&packet->message)) {
    if (!for_this_vehicle(clear->target_system)) return Inbound{};
    return on_clear(from, clear->mission_type, now);
  }
  if (const auto* set = std::get_if<mav::MissionSetCurrent>(&packet->message)) {
    if (!for_this_vehicle(set->target_system)) return Inbound{};
    const Flown f = flown();
    const std::uint32_t index = last_waypoint_.value_or(f.index_offset);
    const auto current = static_cast<std::uint16_t>(index >= f.index_offset ? index - f.index_offset : 0);
    return Inbound{.replies = {mav::status_text(mav::Severity::Warning, "MISSION_SET_CURRENT refused: flown in order"),
                               mav::MissionCurrent{.seq = current, .total = static_cast<std::uint16_t>(f.waypoints.size()),
                                                   .mission_state = 0, .mission_mode = 0, .mission_id = 0,
                                                   .fence_id = 0, .rally_points_id = 0}}};
  }
  if (const auto* command = std::get_if<mav::CommandLong>(&packet->message)) {
    if (!for_this_vehicle(command->target_system) || !for_this_component(command->target_component)) return Inbound{};
    return on_command(from, command->command, {command->param1, command->param2}, now);
  }
  if (const auto* command = std::get_if<mav::CommandInt>(&packet->message)) {
    if (!for_this_vehicle(command->target_system) || !for_this_component(command->target_component)) return Inbound{};
    return on_command(from, command->command, {command->param1, command->param2}, now);
  }
  if (std::holds_alternative<mav::ParamRequestList>(packet->message) ||
      std::holds_alternative<mav::ParamRequestRead>(packet->message) ||
      std::holds_alternative<mav::ParamSet>(packet->message)) {
    return on_param(packet->message);
  }
  return Inbound{};  // HEARTBEAT and the rest: valid (the sender is the ground station), nothing to answer
}

ExtLink::Inbound ExtLink::on_command(const mav::FrameHeader& from, std::uint16_t command, std::array<float, 2> param12,
                                     Nanos now) {
  // MAV_CMD values (common.xml).
  constexpr std::uint16_t kMissionStart = 300;
  constexpr std::uint16_t kArmDisarm = 400;
  constexpr std::uint16_t kRequestMessage = 512;
  constexpr std::uint16_t kRequestAutopilotCapabilities = 520;
  const auto time_boot_ms = static_cast<std::uint32_t>(now.count() / 1'000'000);
  switch (command) {
    case kRequestMessage: {
      const float id = param12[0];
      if (id == static_cast<float>(mav::AutopilotVersion::kId)) {
        return Inbound{.replies = {command_ack(from, command, kResultAccepted), autopilot_version()}};
      }
      if (id == static_cast<float>(mav::HomePosition::kId)) {
        if (!home_) return Inbound{.replies = {command_ack(from, command, kResultFailed)}, .note = "HOME_POSITION asked for: no home on Earth"};
        return Inbound{.replies = {command_ack(from, command, kResultAccepted), home_position(time_boot_ms)}};
      }
      return Inbound{.replies = {command_ack(from, command, kResultUnsupported)}};
    }
    case kRequestAutopilotCapabilities:
      return Inbound{.replies = {command_ack(from, command, kResultAccepted), autopilot_version()}};
    case kMissionStart:
      // The vehicle flies its mission in AUTO from take-off on; there is nothing else to start.
      return Inbound{.replies = {command_ack(from, command, kResultAccepted)}};
    case kArmDisarm:
      // Armed from boot to the end of the flight: arming is a no-op, disarming in flight is refused.
      return Inbound{.replies = {command_ack(from, command, param12[0] == 1.0F ? kResultAccepted : kResultDenied)}};
    case kCmdReturnToLaunch: {
      // Back to home (the launch mission's first waypoint, at its altitude) as a one-waypoint mission on
      // mission_upload: commander checks it as any upload, and gen_set_point flies it from the current setpoint.
      const std::vector<mav::LocalWaypoint> home{local_of(guard_.home)};
      rejuv_msg_MissionWaypoints upload = to_message(home, launch_mission_.acceptance_radius_m, now);
      if (auto valid = flight_io::validate_upload(upload, guard_.home, guard_.bounds); !valid) {
        return Inbound{.replies = {command_ack(from, command, kResultDenied)},
                       .note = "return to launch refused: " + valid.error().message};
      }
      return Inbound{.replies = {},
                     .forward = Forward{.upload = upload, .waypoints = home, .ground_system = from.sysid,
                                        .ground_component = from.compid, .request = Request::ReturnToLaunch},
                     .note = std::nullopt};
    }
    default: return Inbound{.replies = {command_ack(from, command, kResultUnsupported)}};
  }
}

ExtLink::Inbound ExtLink::on_param(const mav::Message& message) {
  if (const auto* list = std::get_if<mav::ParamRequestList>(&message)) {
    if (!for_this_vehicle(list->target_system) || !for_this_component(list->target_component)) return Inbound{};
    Inbound in;
    for (std::size_t i = 0; i < params_.size(); ++i) in.replies.emplace_back(param_value(i));
    return in;
  }
  const auto find = [&](const std::array<char, 16>& id) -> std::optional<std::size_t> {
    const std::string name = name_of(id);
    for (std::size_t i = 0; i < params_.size(); ++i) {
      if (params_[i].name == name) return i;
    }
    return std::nullopt;
  };
  if (const auto* read = std::get_if<mav::ParamRequestRead>(&message)) {
    if (!for_this_vehicle(read->target_system) || !for_this_component(read->target_component)) return Inbound{};
    const std::optional<std::size_t> at =
        read->param_index >= 0 ? (static_cast<std::size_t>(read->param_index) < params_.size()
                                      ? std::optional<std::size_t>(static_cast<std::size_t>(read->param_index))
                                      : std::nullopt)
                               : find(read->param_id);
    if (!at) return Inbound{};  // the protocol's answer to an unknown param: none
    return Inbound{.replies = {param_value(*at)}};
  }
  const auto& set = std::get<mav::ParamSet>(message);
  if (!for_this_vehicle(set.target_system) || !for_this_component(set.target_component)) return Inbound{};
  const std::optional<std::size_t> at = find(set.param_id);
  if (!at) return Inbound{.replies = {mav::status_text(mav::Severity::Warning, "param " + name_of(set.param_id) + ": unknown")}};
  // Launch values are fixed for the flight (the SEI's guarantees rest on them): answered with the value kept.
  return Inbound{.replies = {mav::status_text(mav::Severity::Warning, "param " + params_[*at].name + " is read-only in flight"),
                             param_value(*at)}};
}

void ExtLink::observe_setpoint(const rejuv_msg_Setpoint& setpoint) {
  setpoint_ = mav::LocalWaypoint{.north_m = setpoint.p_N_m[0], .east_m = setpoint.p_N_m[1], .down_m = setpoint.p_N_m[2],
                                 .yaw_rad = setpoint.yaw_rad};
}

ExtLink::Inbound ExtLink::on_clear(const mav::FrameHeader& from, std::uint8_t mission_type, Nanos now) {
  // MAV_MISSION_TYPE: MISSION 0, FENCE 1, RALLY 2, ALL 255.
  constexpr std::uint8_t kFence = 1, kRally = 2, kAll = 255;
  if (mission_type == kFence || mission_type == kRally) {  // there are none: cleared
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Accepted, mission_type)}};
  }
  if (mission_type != mav::kMissionTypeMission && mission_type != kAll) {
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Unsupported, mission_type)}};
  }
  receiving_.reset();  // a clear ends an upload in progress
  // The vehicle cannot stop flying: cleared, it holds where its setpoint is, PX4's Hold after a clear. That is a
  // one-waypoint mission at x_sp, published like an upload through commander's checks; gen_set_point's path
  // from x_sp to itself keeps x_sp where it is (paper §IV-A's update rule moves it nowhere).
  if (!setpoint_) {
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Error, mission_type)},
                   .note = "MISSION_CLEAR_ALL refused: no setpoint seen yet to hold at"};
  }
  const std::vector<mav::LocalWaypoint> hold{*setpoint_};
  if (last_forwarded_ && *last_forwarded_ == hold) {
    // The clear again (its ack lost, or cleared twice in one window): acknowledged, not republished.
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Accepted, mission_type)}};
  }
  rejuv_msg_MissionWaypoints upload = to_message(hold, flown().acceptance_radius_m, now);
  if (auto valid = flight_io::validate_upload(upload, guard_.home, guard_.bounds); !valid) {
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Error, mission_type)},
                   .note = "MISSION_CLEAR_ALL refused: holding at the setpoint fails the upload check: " +
                           valid.error().message};
  }
  return Inbound{.replies = {},
                 .forward = Forward{.upload = upload, .waypoints = hold, .ground_system = from.sysid,
                                    .ground_component = from.compid, .request = Request::Clear,
                                    .mission_type = mission_type},
                 .note = std::nullopt};
}

ExtLink::Inbound ExtLink::on_count(const mav::FrameHeader& from, const mav::MissionCount& count, Nanos now) {
  if (count.mission_type != mav::kMissionTypeMission) {
    // No fence or rally storage: refused with the type asked for, as the protocol says.
    return Inbound{.replies = {ack(from.sysid, from.compid, mav::MissionResult::Unsupported, count.mission_type)}};
  }
  if (count.count == 0) return on_clear(from, count.mission_type, now);  // an empty mission: the protocol's clear
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
        mav::waypoint_in_frame(item, home_) == last_forwarded_->back()) {
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
  const std::optional<mav::LocalWaypoint> waypoint = mav::waypoint_in_frame(item, home_);
  if (!waypoint) {
    return refuse(mav::MissionResult::UnsupportedFrame,
                  "item " + std::to_string(item.seq) + ": frame " + std::to_string(item.frame) +
                      (home_ ? " (LOCAL_NED, GLOBAL(_INT), GLOBAL_RELATIVE_ALT(_INT) accepted)"
                             : " (only MAV_FRAME_LOCAL_NED: no home on Earth)"));
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
  r.waypoints.push_back(*waypoint);
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
  last_forwarded_radius_m_ = forward.upload.acceptance_radius_m;
  switch (forward.request) {
    case Request::ReturnToLaunch:
      return mav::CommandAck{.command = kCmdReturnToLaunch, .result = kResultAccepted, .progress = 0, .result_param2 = 0,
                             .target_system = forward.ground_system, .target_component = forward.ground_component};
    case Request::Upload:
    case Request::Clear: break;
  }
  return ack(forward.ground_system, forward.ground_component, mav::MissionResult::Accepted, forward.mission_type);
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
  const Flown mission = flown();
  if (!last_slow_ || in.now - *last_slow_ >= std::chrono::seconds{1}) {
    last_slow_ = in.now;
    append_slow_set(in, mission, time_boot_ms, out);
  }
  // The setpoint moved on to the next waypoint: the one before is reached (mission protocol "Mission
  // progress"); the last one when the mission is done. Path indices run ahead of the items of an uploaded
  // mission by one (its path starts at the setpoint it was applied at, which is no item). A rollback may
  // restore an older index; the one reached is then reported again.
  if (in.setpoint != nullptr) {
    observe_setpoint(*in.setpoint);
    const std::uint32_t index = in.setpoint->waypoint_index;
    if (last_waypoint_ && index > *last_waypoint_ && index - 1 >= mission.index_offset) {
      out.emplace_back(mav::MissionItemReached{.seq = static_cast<std::uint16_t>(index - 1 - mission.index_offset)});
    }
    if (in.setpoint->mission_done != 0 && !reported_done_ && index >= mission.index_offset) {
      out.emplace_back(mav::MissionItemReached{.seq = static_cast<std::uint16_t>(index - mission.index_offset)});
    }
    reported_done_ = in.setpoint->mission_done != 0;
    last_waypoint_ = index;
  }
  if (in.gps != nullptr && home_ && (!last_gps_ns_ || in.gps->timestamp_ns != *last_gps_ns_)) {
    last_gps_ns_ = in.gps->timestamp_ns;
    out.emplace_back(gps_raw(*home_, *in.gps));
  }
  if (in.state != nullptr) append_estimate(*in.state, time_boot_ms, out);
  return out;
}

void ExtLink::append_slow_set(const TelemetryInputs& in, const Flown& mission, std::uint32_t time_boot_ms,
                              std::vector<mav::Message>& out) {
  out.emplace_back(mav::Heartbeat{.custom_mode = custom_mode_of(in.mode, in.epoch),
                                  .type = mav::kMavTypeQuadrotor,
                                  .autopilot = mav::kMavAutopilotGeneric,
                                  .base_mode = static_cast<std::uint8_t>(mav::kModeFlagCustomModeEnabled |
                                                                         mav::kModeFlagAutoEnabled |
                                                                         mav::kModeFlagSafetyArmed),
                                  .system_status = mav::kMavStateActive,
                                  .mavlink_version = 3});
  out.emplace_back(sys_status(in));
  // MAV_LANDED_STATE: in the air above 0.2 m (the plant's ground is home's altitude).
  const bool in_air = in.state != nullptr && -in.state->p_N_m[2] > 0.2;
  out.emplace_back(mav::ExtendedSysState{.vtol_state = 0, .landed_state = static_cast<std::uint8_t>(in_air ? 2 : 1)});
  if (home_) out.emplace_back(home_position(time_boot_ms));
  if (in.setpoint != nullptr) {
    const std::uint32_t index = in.setpoint->waypoint_index;
    const std::uint32_t item = index >= mission.index_offset ? index - mission.index_offset : 0;
    // MISSION_STATE: ACTIVE (3), COMPLETE (5).
    out.emplace_back(mav::MissionCurrent{.seq = static_cast<std::uint16_t>(item),
                                         .total = static_cast<std::uint16_t>(mission.waypoints.size()),
                                         .mission_state = static_cast<std::uint8_t>(in.setpoint->mission_done != 0 ? 5 : 3),
                                         .mission_mode = 1,  // in a mission mode (AUTO)
                                         .mission_id = 0, .fence_id = 0, .rally_points_id = 0});
  }
}

void ExtLink::append_estimate(const rejuv_msg_VehicleStateEstimate& s, std::uint32_t time_boot_ms,
                              std::vector<mav::Message>& out) const {
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
  // VFR_HUD: no air data and no wind model in the estimate: airspeed is the ground speed; the throttle is not
  // seen by ext_link (0).
  const double ground_speed = std::hypot(s.v_N_m_s[0], s.v_N_m_s[1]);
  double heading_deg = std::fmod(yaw * 180.0 / std::numbers::pi + 360.0, 360.0);
  if (!std::isfinite(heading_deg)) heading_deg = 0;
  out.emplace_back(mav::VfrHud{.airspeed = static_cast<float>(ground_speed),
                               .groundspeed = static_cast<float>(ground_speed),
                               .alt = static_cast<float>((home_ ? home_->alt_m : 0.0) - s.p_N_m[2]),
                               .climb = static_cast<float>(-s.v_N_m_s[2]),
                               .heading = static_cast<std::int16_t>(std::min(359.0, std::floor(heading_deg))),
                               .throttle = 0});
}

mav::SysStatus ExtLink::sys_status(const TelemetryInputs& in) {
  // MAV_SYS_STATUS_SENSOR bits. Present and enabled: what the graph flies with (the IMU, magnetometer and
  // barometer behind the estimate, GPS when ext_link sees its samples, the AHRS and the controllers). Healthy:
  // what was seen working since the last report — a new estimate for the sensors behind it and the AHRS, a
  // new GPS sample with a 3D fix, a new setpoint for the control loops.
  constexpr std::uint32_t kGyro = 1U, kAccel = 2U, kMag = 4U, kBaro = 8U, kGps = 32U, kRate = 1024U,
                          kAttitude = 2048U, kYaw = 4096U, kAltitude = 8192U, kPosition = 16384U, kAhrs = 0x200000U;
  constexpr std::uint32_t kEstimate = kGyro | kAccel | kMag | kBaro | kAhrs;
  constexpr std::uint32_t kControl = kRate | kAttitude | kYaw | kAltitude | kPosition;
  mav::SysStatus sys{};
  sys.onboard_control_sensors_present = kEstimate | kControl | (in.gps != nullptr ? kGps : 0U);
  sys.onboard_control_sensors_enabled = sys.onboard_control_sensors_present;
  std::uint32_t health = 0;
  if (in.state != nullptr && in.state->timestamp_ns != health_seen_.state_ns) health |= kEstimate;
  if (in.gps != nullptr && in.gps->timestamp_ns != health_seen_.gps_ns && in.gps->fix_type >= 3) health |= kGps;
  if (in.setpoint != nullptr && in.setpoint->timestamp_ns != health_seen_.setpoint_ns) health |= kControl;
  health_seen_ = HealthSeen{.state_ns = in.state != nullptr ? in.state->timestamp_ns : 0,
                            .gps_ns = in.gps != nullptr ? in.gps->timestamp_ns : 0,
                            .setpoint_ns = in.setpoint != nullptr ? in.setpoint->timestamp_ns : 0};
  sys.onboard_control_sensors_health = health;
  sys.battery_remaining = -1;  // no battery model
  sys.current_battery = -1;
  sys.voltage_battery = 0xFFFF;
  return sys;
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
