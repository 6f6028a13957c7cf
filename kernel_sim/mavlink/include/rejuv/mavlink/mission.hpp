// The MAVLink mission protocol's upload, both ends (https://mavlink.io/en/services/mission.html "Upload a
// Mission to the Vehicle"): the ground sends MISSION_COUNT, the vehicle requests each item with
// MISSION_REQUEST_INT, the ground answers with MISSION_ITEM_INT, and the vehicle ends the transaction with a
// MISSION_ACK (MAV_MISSION_ACCEPTED or an error code). Items are MAV_CMD_NAV_WAYPOINT in MAV_FRAME_LOCAL_NED:
// MISSION_ITEM_INT x, y = north, east [m] · 10⁴, z = down [m], param2 = acceptance radius [m], param4 = yaw
// [deg]; or in the global frames ground stations plan in (MAV_FRAME_GLOBAL(_INT): x, y = latitude, longitude
// [deg] · 10⁷, z = altitude AMSL [m]; MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT): z = altitude above home [m]),
// converted against home on Earth (GeoHome) by the flat-Earth projection PX4's map_projection uses. Here: the item conversion both ends share, and the ground side's state machine (`rejuv gcs` and the
// tests); the vehicle side is ext_link's (services/ext_link).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "rejuv/mavlink/messages.hpp"

namespace rejuv::mavlink {

// A waypoint of an upload in local NED (home is the origin of the vehicle's local frame).
struct LocalWaypoint {
  double north_m = 0;
  double east_m = 0;
  double down_m = 0;  // 3 m up is −3
  double yaw_rad = 0;
  friend bool operator==(const LocalWaypoint&, const LocalWaypoint&) = default;
};

inline constexpr double kLocalIntScale = 1e4;  // MISSION_ITEM_INT x, y in MAV_FRAME_LOCAL_NED: metres · 10⁴
inline constexpr double kGlobalIntScale = 1e7;  // MISSION_ITEM_INT x, y in the global frames: degrees · 10⁷

// MAV_FRAME values of the mission items accepted (common.xml MAV_FRAME).
inline constexpr std::uint8_t kMavFrameGlobal = 0;               // lat/lon, altitude AMSL
inline constexpr std::uint8_t kMavFrameGlobalRelativeAlt = 3;    // lat/lon, altitude above home
inline constexpr std::uint8_t kMavFrameGlobalInt = 5;            // deprecated alias of GLOBAL for *_INT messages
inline constexpr std::uint8_t kMavFrameGlobalRelativeAltInt = 6; // deprecated alias of GLOBAL_RELATIVE_ALT

// Where the local frame's origin (home) is on Earth: WGS-84 latitude and longitude [deg], altitude AMSL [m].
struct GeoHome {
  double lat_deg = 0;
  double lon_deg = 0;
  double alt_m = 0;
  friend bool operator==(const GeoHome&, const GeoHome&) = default;
};
// PX4 SITL's default home (Zürich Irchel park), the shipped launch graphs' home.
inline constexpr GeoHome kPx4SitlHome{.lat_deg = 47.397742, .lon_deg = 8.545594, .alt_m = 488.0};

// A point near home on Earth and back (flat Earth on a sphere of the WGS-84 equatorial radius; the geofence
// keeps the vehicle within metres of home, where the error is far below a millimetre).
struct GeoPoint {
  double lat_deg = 0;
  double lon_deg = 0;
  double alt_m = 0;  // AMSL
};
[[nodiscard]] GeoPoint global_of(const GeoHome& home, double north_m, double east_m, double down_m);
// north, east, down [m] of a point on Earth (altitude AMSL [m]).
[[nodiscard]] LocalWaypoint local_of(const GeoHome& home, double lat_deg, double lon_deg, double alt_m);

// The waypoint of a MAV_CMD_NAV_WAYPOINT item in any accepted frame (global frames need home; nullopt: a
// frame not accepted, or a global frame without home). A NaN yaw ("keep the current yaw") becomes 0.
[[nodiscard]] std::optional<LocalWaypoint> waypoint_in_frame(const MissionItemInt& item, const std::optional<GeoHome>& home);
// An item in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT (what QGroundControl plans in).
[[nodiscard]] MissionItemInt global_item(const GeoHome& home, const LocalWaypoint& w, std::uint16_t seq,
                                         double acceptance_radius_m, std::uint8_t target_system,
                                         std::uint8_t target_component);

[[nodiscard]] MissionItemInt local_item(const LocalWaypoint& w, std::uint16_t seq, double acceptance_radius_m,
                                        std::uint8_t target_system, std::uint8_t target_component);
// The waypoint of an item the caller has checked to be MAV_CMD_NAV_WAYPOINT in MAV_FRAME_LOCAL_NED
// (x, y scaled back; a NaN yaw — "keep the current yaw" — becomes 0).
[[nodiscard]] LocalWaypoint waypoint_of(const MissionItemInt& item);

// The ground side of one upload. The transaction survives what the vehicle's rollbacks do to it: a request
// or an ack lost in the secure interval is recovered by retransmitting the last message (retry(), on the
// ground station's timeout), and a MAV_MISSION_INVALID_SEQUENCE / OPERATION_CANCELLED ack before the end
// (the vehicle lost the transaction) restarts it with MISSION_COUNT.
class MissionUploader {
 public:
  enum class Status : std::uint8_t { InProgress, Accepted, Refused };
  MissionUploader(std::vector<LocalWaypoint> waypoints, double acceptance_radius_m, std::uint8_t target_system = 1,
                  std::uint8_t target_component = 1);
  // Items sent in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT against `home` (as QGroundControl plans) instead of LOCAL_NED.
  void plan_in_global(const GeoHome& home) { global_home_ = home; }

  [[nodiscard]] Message start();  // MISSION_COUNT
  // What to send in answer to a message from the vehicle (nothing: it is not about this upload).
  [[nodiscard]] std::optional<Message> on_message(const Message& message);
  [[nodiscard]] const Message& last_sent() const { return last_; }
  [[nodiscard]] Status status() const { return status_; }
  [[nodiscard]] MissionResult result() const { return result_; }  // Accepted, or the vehicle's error code
  [[nodiscard]] std::uint32_t restarts() const { return restarts_; }

 private:
  std::vector<LocalWaypoint> waypoints_;
  std::optional<GeoHome> global_home_{};
  double acceptance_radius_m_;
  std::uint8_t target_system_;
  std::uint8_t target_component_;
  Message last_{};
  Status status_ = Status::InProgress;
  MissionResult result_ = MissionResult::Accepted;
  bool requested_any_ = false;
  std::uint32_t restarts_ = 0;
};

}  // namespace rejuv::mavlink
