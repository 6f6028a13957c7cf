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
  // The one validator of the ground link (ext_link ran it already to answer the ground station).
  auto mission = flight_io::validate_upload(upload, mission_.waypoints.front(), bounds_);
  if (!mission) {
    return fail(UploadRefusal{.kind = mission.error().check == flight_io::UploadCheck::Invalid ? UploadError::Invalid
                                                                                              : UploadError::Bounds,
                              .message = mission.error().message});
  }
  return std::move(*mission);
}

}  // namespace rejuv::services
