// The `commander` service (paper §IV-B: "we upload the mission ... through the PX4 commander"; docs/design.md §4
// `lateral`): the only path from the ground to the mission.
//
// Topics: out mission (MissionWaypoints), published once at start from the launch graph's mission; in
// mission_upload (from ext_link, in MC) — validated here (flight_io::check_upload: count, geofence, altitude
// floor) and, if valid, kept in the Persistent cell uploaded_mission, which gen_set_point applies at the
// next setpoint update (docs/mavlink.md "Mission upload") — and sr_mode (uploads are expected in MC only:
// the SEI has no network).
//
// Params — the launch graph's mission, as the kernel passes it to every service (sdk/service.hpp):
//   mission.count                 number of waypoints, 1 … 16 (absent: the simulation's default mission)
//   mission.<i>.north_m           waypoint i, i = 0 … count-1, local NED [m]   (required)
//   mission.<i>.east_m                                                          (required)
//   mission.<i>.down_m            (−3 is 3 m up)                                (required)
//   mission.<i>.yaw_rad           heading at waypoint i [rad]                   (default 0)
//   mission.acceptance_radius_m   when the last waypoint counts as reached [m]  (absent or 0: 0.05)
// A bad mission (more than 16 waypoints, a missing or non-finite coordinate) is refused with the name of the
// param at fault, and the service exits without publishing anything.
#pragma once

#include "rejuv/flight_io/mission_record.hpp"

#include <cstdint>

#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::services {

class Commander {
 public:
  [[nodiscard]] static Result<Commander, flight_io::InputFailure> from_params(
      const flight_io::Params& params);

  // The mission to publish at start, stamped t.
  [[nodiscard]] rejuv_msg_MissionWaypoints mission_message(Nanos t) const;
  [[nodiscard]] const flight_io::MissionSpec& mission() const { return mission_; }

  // The mission_upload hook: the upload, validated, or why it is refused. Outside MC an upload is refused
  // (the network is off in the SEI, so one arriving then did not come from the ground link).
  // Invalid: a field mission_from_message refuses; Bounds: flight_io::check_upload refuses it (too many
  // waypoints, outside the geofence around home, below the altitude floor).
  enum class UploadError : std::uint8_t { OutsideMissionControl, Invalid, Bounds };
  struct UploadRefusal {
    UploadError kind = UploadError::Invalid;
    std::string message{};
    [[nodiscard]] std::string to_string() const { return message; }
  };
  [[nodiscard]] Result<flight_io::MissionSpec, UploadRefusal> validate_upload(
      const rejuv_msg_MissionWaypoints& upload, SrMode mode) const;

 private:
  Commander(flight_io::MissionSpec mission, flight_io::UploadBounds bounds)
      : mission_(std::move(mission)), bounds_(bounds) {}
  flight_io::MissionSpec mission_;
  flight_io::UploadBounds bounds_;
};

}  // namespace rejuv::services
