#include "rejuv/services/commander/commander.hpp"

#include <string>
#include <utility>

namespace rejuv::services {

Result<Commander, flight_io::InputFailure> Commander::from_params(const flight_io::Params& params) {
  auto mission = flight_io::mission_params(params);
  if (!mission) return fail(std::move(mission.error()));
  auto bounds = flight_io::upload_bounds(params);
  if (!bounds) return fail(std::move(bounds.error()));
  return Commander(std::move(*mission), *bounds);
}

rejuv_msg_MissionWaypoints Commander::mission_message(Nanos t) const {
  return flight_io::mission_message(mission_, t);
}

Result<flight_io::MissionSpec, Commander::UploadRefusal> Commander::validate_upload(
    const rejuv_msg_MissionWaypoints& upload, SrMode mode) const {
  if (mode != SrMode::MC) {
    return fail(UploadRefusal{.kind = UploadError::OutsideMissionControl,
                              .message = "mission upload in mode " + std::string(to_string(mode)) +
                                         ": the ground link is off outside MC"});
  }
  auto mission = flight_io::mission_from_message(upload);
  if (!mission) {
    return fail(UploadRefusal{.kind = UploadError::Invalid, .message = mission.error().to_string()});
  }
  std::size_t where = 0;
  if (const auto check = flight_io::check_upload(*mission, mission_.waypoints.front(), bounds_, &where);
      check != flight_io::UploadCheck::Accepted) {
    return fail(UploadRefusal{.kind = UploadError::Bounds,
                              .message = std::string(flight_io::to_string(check)) +
                                         (check == flight_io::UploadCheck::TooManyWaypoints
                                              ? ""
                                              : " (waypoint " + std::to_string(where) + ")")});
  }
  return std::move(*mission);
}

}  // namespace rejuv::services
