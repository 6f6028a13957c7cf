#include "rejuv/mavlink/mission.hpp"

#include <cmath>
#include <numbers>

namespace rejuv::mavlink {

MissionItemInt local_item(const LocalWaypoint& w, std::uint16_t seq, double acceptance_radius_m,
                          std::uint8_t target_system, std::uint8_t target_component) {
  MissionItemInt item{};
  item.param2 = static_cast<float>(acceptance_radius_m);
  item.param4 = static_cast<float>(w.yaw_rad * 180.0 / std::numbers::pi);
  item.x = static_cast<std::int32_t>(std::lround(w.north_m * kLocalIntScale));
  item.y = static_cast<std::int32_t>(std::lround(w.east_m * kLocalIntScale));
  item.z = static_cast<float>(w.down_m);
  item.seq = seq;
  item.command = kMavCmdNavWaypoint;
  item.target_system = target_system;
  item.target_component = target_component;
  item.frame = kMavFrameLocalNed;
  item.current = seq == 0 ? 1 : 0;
  item.autocontinue = 1;
  item.mission_type = kMissionTypeMission;
  return item;
}

LocalWaypoint waypoint_of(const MissionItemInt& item) {
  return LocalWaypoint{.north_m = item.x / kLocalIntScale,
                       .east_m = item.y / kLocalIntScale,
                       .down_m = static_cast<double>(item.z),
                       .yaw_rad = std::isnan(item.param4) ? 0.0 : static_cast<double>(item.param4) * std::numbers::pi / 180.0};
}

namespace {
constexpr double kEarthRadius_m = 6'378'137.0;  // WGS-84 equatorial radius
constexpr double kRadPerDeg = std::numbers::pi / 180.0;
}  // namespace

GeoPoint global_of(const GeoHome& home, double north_m, double east_m, double down_m) {
  return GeoPoint{.lat_deg = home.lat_deg + north_m / kEarthRadius_m / kRadPerDeg,
                  .lon_deg = home.lon_deg + east_m / (kEarthRadius_m * std::cos(home.lat_deg * kRadPerDeg)) / kRadPerDeg,
                  .alt_m = home.alt_m - down_m};
}

LocalWaypoint local_of(const GeoHome& home, double lat_deg, double lon_deg, double alt_m) {
  return LocalWaypoint{.north_m = (lat_deg - home.lat_deg) * kRadPerDeg * kEarthRadius_m,
                       .east_m = (lon_deg - home.lon_deg) * kRadPerDeg * kEarthRadius_m * std::cos(home.lat_deg * kRadPerDeg),
                       .down_m = home.alt_m - alt_m,
                       .yaw_rad = 0};
}

std::optional<LocalWaypoint> waypoint_in_frame(const MissionItemInt& item, const std::optional<GeoHome>& home) {
  const double yaw_rad = std::isnan(item.param4) ? 0.0 : static_cast<double>(item.param4) * kRadPerDeg;
  switch (item.frame) {
    case kMavFrameLocalNed: return waypoint_of(item);
    case kMavFrameGlobal:
    case kMavFrameGlobalInt:
    case kMavFrameGlobalRelativeAlt:
    case kMavFrameGlobalRelativeAltInt: {
      if (!home) return std::nullopt;
      const bool relative = item.frame == kMavFrameGlobalRelativeAlt || item.frame == kMavFrameGlobalRelativeAltInt;
      const double alt_m = static_cast<double>(item.z) + (relative ? home->alt_m : 0.0);
      LocalWaypoint w = local_of(*home, item.x / kGlobalIntScale, item.y / kGlobalIntScale, alt_m);
      w.yaw_rad = yaw_rad;
      return w;
    }
    default: return std::nullopt;
  }
}

MissionItemInt global_item(const GeoHome& home, const LocalWaypoint& w, std::uint16_t seq, double acceptance_radius_m,
                           std::uint8_t target_system, std::uint8_t target_component) {
  MissionItemInt item = local_item(w, seq, acceptance_radius_m, target_system, target_component);
  const GeoPoint p = global_of(home, w.north_m, w.east_m, w.down_m);
  item.frame = kMavFrameGlobalRelativeAltInt;
  item.x = static_cast<std::int32_t>(std::lround(p.lat_deg * kGlobalIntScale));
  item.y = static_cast<std::int32_t>(std::lround(p.lon_deg * kGlobalIntScale));
  item.z = static_cast<float>(-w.down_m);  // [m] above home
  return item;
}

MissionUploader::MissionUploader(std::vector<LocalWaypoint> waypoints, double acceptance_radius_m,
                                 std::uint8_t target_system, std::uint8_t target_component)
    : waypoints_(std::move(waypoints)),
      acceptance_radius_m_(acceptance_radius_m),
      target_system_(target_system),
      target_component_(target_component) {}

Message MissionUploader::start() {
  last_ = MissionCount{.count = static_cast<std::uint16_t>(waypoints_.size()),
                       .target_system = target_system_,
                       .target_component = target_component_,
                       .mission_type = kMissionTypeMission,
                       .opaque_id = 0};
  requested_any_ = false;
  return last_;
}

std::optional<Message> MissionUploader::on_message(const Message& message) {
  if (status_ != Status::InProgress) return std::nullopt;
  if (const auto* request = std::get_if<MissionRequestInt>(&message)) {
    if (request->mission_type != kMissionTypeMission || request->seq >= waypoints_.size()) return std::nullopt;
    requested_any_ = true;
    last_ = global_home_ ? global_item(*global_home_, waypoints_[request->seq], request->seq, acceptance_radius_m_,
                                       target_system_, target_component_)
                         : local_item(waypoints_[request->seq], request->seq, acceptance_radius_m_, target_system_,
                                      target_component_);
    return last_;
  }
  if (const auto* ack = std::get_if<MissionAck>(&message)) {
    if (ack->mission_type != kMissionTypeMission) return std::nullopt;
    const auto result = static_cast<MissionResult>(ack->type);
    if (result == MissionResult::Accepted) {
      status_ = Status::Accepted;
      result_ = result;
      return std::nullopt;
    }
    // The vehicle lost the transaction (a rollback wiped it): start again.
    if (result == MissionResult::InvalidSequence || result == MissionResult::OperationCancelled) {
      ++restarts_;
      return start();
    }
    status_ = Status::Refused;
    result_ = result;
    return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace rejuv::mavlink
