// The MAVLink mission protocol's upload, both ends (https://mavlink.io/en/services/mission.html "Upload a
// Mission to the Vehicle"): the ground sends MISSION_COUNT, the vehicle requests each item with
// MISSION_REQUEST_INT, the ground answers with MISSION_ITEM_INT, and the vehicle ends the transaction with a
// MISSION_ACK (MAV_MISSION_ACCEPTED or an error code). Items are MAV_CMD_NAV_WAYPOINT in MAV_FRAME_LOCAL_NED:
// MISSION_ITEM_INT x, y = north, east [m] · 10⁴, z = down [m], param2 = acceptance radius [m], param4 = yaw
// [deg]. Here: the item conversion both ends share, and the ground side's state machine (`rejuv gcs` and the
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

  [[nodiscard]] Message start();  // MISSION_COUNT
  // What to send in answer to a message from the vehicle (nothing: it is not about this upload).
  [[nodiscard]] std::optional<Message> on_message(const Message& message);
  [[nodiscard]] const Message& last_sent() const { return last_; }
  [[nodiscard]] Status status() const { return status_; }
  [[nodiscard]] MissionResult result() const { return result_; }  // Accepted, or the vehicle's error code
  [[nodiscard]] std::uint32_t restarts() const { return restarts_; }

 private:
  std::vector<LocalWaypoint> waypoints_;
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
