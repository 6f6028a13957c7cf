// The mission state the kernel keeps for the flight services (paper §III "Persistent data"; docs/design.md §7 "Cold
// restart"): the mission being flown, where the setpoint is on it (x_sp follows from the path cursor) and
// whether it is done. It lives in the Persistent cell `mission_state`, which survives rollbacks and cold
// restarts; gen_set_point writes it after each setpoint update — only in UPDATE, inside the secure execution
// interval — and the services restarted from their binaries read it at boot. The same layout, with the
// cursor at the start, carries a validated mission upload from commander to gen_set_point (the cell
// `mission_upload`, docs/mavlink.md "Mission upload").
//
// Layout (host byte order: written and read on one machine), kMissionRecordBytes bytes:
//   u32 magic "RJMS", u32 version 1, u32 segment, u32 done (0/1), f64 tau, MissionWaypoints (idl/control.idl).
// A cell never written is all zeros: decode returns nullopt for it.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <span>
#include <string>

#include "rejuv/core/result.hpp"
#include "rejuv/flight/setpoint.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::flight_io {

struct MissionRecord {
  MissionSpec mission{};
  flight::PathCursor cursor{};  // where x_sp is: segment and τ (the start: 0, 0)
  bool done = false;            // mission_done was latched
};

inline constexpr std::size_t kMissionRecordBytes = 24 + sizeof(rejuv_msg_MissionWaypoints);
// The size of the policy's PERSISTENT cells that hold one (policies/quad_sr.policy.pbtxt).
inline constexpr std::size_t kMissionCellBytes = 1024;
static_assert(kMissionRecordBytes <= kMissionCellBytes);

using MissionRecordBytes = std::array<std::byte, kMissionRecordBytes>;
// Precondition: 1 … kMaxWaypoints waypoints.
[[nodiscard]] MissionRecordBytes encode_mission_record(const MissionRecord& record);
// nullopt: the cell was never written (all zeros). A failure names the field: a bad magic or version, a
// mission that mission_from_message refuses, a cursor off the path, a done flag other than 0/1.
[[nodiscard]] Result<std::optional<MissionRecord>, InputFailure> decode_mission_record(
    std::span<const std::byte> bytes);

// Where an uploaded mission may take the vehicle (docs/mavlink.md "Mission upload"): horizontally within
// geofence_radius_m of home (the launch graph's first waypoint), at least min_altitude_m above it, and at most
// kMaxWaypoints − 1 waypoints (the path flown starts at the current setpoint). Service params override the
// defaults: geofence.radius_m, geofence.min_altitude_m.
struct UploadBounds {
  double geofence_radius_m = 10.0;
  double min_altitude_m = 1.0;
};
[[nodiscard]] Result<UploadBounds, InputFailure> upload_bounds(const Params& params);
enum class UploadCheck : std::uint8_t { Accepted, TooManyWaypoints, OutsideGeofence, BelowAltitudeFloor, Invalid };
[[nodiscard]] std::string_view to_string(UploadCheck check);
// The first bound `upload` breaks (with the waypoint in `where`), or Accepted.
[[nodiscard]] UploadCheck check_upload(const MissionSpec& upload, const flight::PathWaypoint& home,
                                       const UploadBounds& bounds, std::size_t* where = nullptr);

// The whole check a mission upload passes before anything acts on it — the one validator of the ground link:
// ext_link runs it to answer the ground station (a negative acknowledgement names the reason), commander runs
// it again before it keeps the upload, gen_set_point checks the kept record once more. The message must be a
// mission (mission_from_message: Invalid otherwise) that check_upload accepts.
struct UploadRefusal {
  UploadCheck check = UploadCheck::Invalid;  // never Accepted
  std::size_t waypoint = 0;                  // OutsideGeofence, BelowAltitudeFloor: the waypoint at fault
  std::string message{};                     // for logs: the reason, the waypoint or the field at fault
  [[nodiscard]] std::string to_string() const { return message; }
};
[[nodiscard]] Result<MissionSpec, UploadRefusal> validate_upload(const rejuv_msg_MissionWaypoints& upload,
                                                                const flight::PathWaypoint& home,
                                                                const UploadBounds& bounds);

}  // namespace rejuv::flight_io
