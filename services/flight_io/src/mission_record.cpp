#include "rejuv/flight_io/mission_record.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

namespace rejuv::flight_io {

namespace {

constexpr std::uint32_t kMagic = 0x534D4A52U;  // "RJMS"
constexpr std::uint32_t kVersion = 1;

struct Layout {
  std::uint32_t magic;
  std::uint32_t version;
  std::uint32_t segment;
  std::uint32_t done;
  double tau;
  rejuv_msg_MissionWaypoints mission;
};
static_assert(sizeof(Layout) == kMissionRecordBytes);
static_assert(std::is_trivially_copyable_v<Layout>);

InputFailure bad(std::string where, std::string message) {
  return InputFailure{.kind = InputError::OutOfRange, .where = std::move(where), .message = std::move(message)};
}

}  // namespace

MissionRecordBytes encode_mission_record(const MissionRecord& record) {
  Layout l;
  std::memset(&l, 0, sizeof l);  // padding too: the cell's bytes are the record's
  l.magic = kMagic;
  l.version = kVersion;
  l.segment = static_cast<std::uint32_t>(record.cursor.segment);
  l.done = record.done ? 1 : 0;
  l.tau = record.cursor.tau;
  l.mission = mission_message(record.mission, Nanos{0});
  MissionRecordBytes out{};
  std::memcpy(out.data(), &l, sizeof l);
  return out;
}

Result<std::optional<MissionRecord>, InputFailure> decode_mission_record(std::span<const std::byte> bytes) {
  if (bytes.size() < kMissionRecordBytes) {
    return fail(bad("mission record", "expected " + std::to_string(kMissionRecordBytes) + " bytes, got " +
                                          std::to_string(bytes.size())));
  }
  if (std::all_of(bytes.begin(), bytes.end(), [](std::byte b) { return b == std::byte{0}; })) {
    return std::optional<MissionRecord>{};
  }
  Layout l{};
  std::memcpy(&l, bytes.data(), sizeof l);
  if (l.magic != kMagic || l.version != kVersion) {
    return fail(bad("mission record", "not a mission record of version " + std::to_string(kVersion)));
  }
  if (l.done > 1) return fail(bad("mission record.done", "expected 0 or 1"));
  auto mission = mission_from_message(l.mission);
  if (!mission) return fail(std::move(mission.error()));
  const std::size_t segments = mission->waypoints.size() - 1;
  const bool on_path = segments == 0 ? l.segment == 0 && l.tau == 0.0
                                     : l.segment < segments && std::isfinite(l.tau) && l.tau >= 0.0 && l.tau <= 1.0;
  if (!on_path) return fail(bad("mission record.cursor", "expected a point on the mission's path"));
  return std::optional<MissionRecord>(MissionRecord{
      .mission = std::move(*mission), .cursor = {.segment = l.segment, .tau = l.tau}, .done = l.done != 0});
}

Result<UploadBounds, InputFailure> upload_bounds(const Params& params) {
  UploadBounds b;
  const auto read = [&](std::string_view name, double& out) -> Result<void, InputFailure> {
    const auto v = params.find(name);
    if (!v) return {};
    if (!std::isfinite(*v) || *v <= 0.0) {
      return fail(InputFailure{.kind = InputError::OutOfRange, .where = std::string(name), .message = "expected a finite value > 0 m"});
    }
    out = *v;
    return {};
  };
  if (auto ok = read("geofence.radius_m", b.geofence_radius_m); !ok) return fail(std::move(ok.error()));
  if (auto ok = read("geofence.min_altitude_m", b.min_altitude_m); !ok) return fail(std::move(ok.error()));
  return b;
}

std::string_view to_string(UploadCheck check) {
  switch (check) {
    case UploadCheck::Accepted: return "accepted";
    case UploadCheck::TooManyWaypoints: return "too many waypoints";
    case UploadCheck::OutsideGeofence: return "outside the geofence";
    case UploadCheck::BelowAltitudeFloor: return "below the altitude floor";
    case UploadCheck::Invalid: return "not a valid mission";
  }
  return "unknown";
}

UploadCheck check_upload(const MissionSpec& upload, const flight::PathWaypoint& home, const UploadBounds& bounds,
                         std::size_t* where) {
  if (upload.waypoints.empty() || upload.waypoints.size() + 1 > kMaxWaypoints) return UploadCheck::TooManyWaypoints;
  for (std::size_t i = 0; i < upload.waypoints.size(); ++i) {
    if (where != nullptr) *where = i;
    const Eigen::Vector3d d = upload.waypoints[i].p_N_m - home.p_N_m;
    if (!(std::hypot(d.x(), d.y()) <= bounds.geofence_radius_m)) return UploadCheck::OutsideGeofence;
    // NED: altitude is −down, above N's origin (the take-off ground).
    if (!(-upload.waypoints[i].p_N_m.z() >= bounds.min_altitude_m)) return UploadCheck::BelowAltitudeFloor;
  }
  return UploadCheck::Accepted;
}

Result<MissionSpec, UploadRefusal> validate_upload(const rejuv_msg_MissionWaypoints& upload,
                                                  const flight::PathWaypoint& home, const UploadBounds& bounds) {
  auto mission = mission_from_message(upload);
  if (!mission) {
    return fail(UploadRefusal{.check = UploadCheck::Invalid, .waypoint = 0, .message = mission.error().to_string()});
  }
  std::size_t where = 0;
  if (const UploadCheck check = check_upload(*mission, home, bounds, &where); check != UploadCheck::Accepted) {
    const bool names_waypoint = check != UploadCheck::TooManyWaypoints;
    return fail(UploadRefusal{
        .check = check,
        .waypoint = names_waypoint ? where : 0,
        .message = std::string(to_string(check)) + (names_waypoint ? " (waypoint " + std::to_string(where) + ")" : "")});
  }
  return std::move(*mission);
}

}  // namespace rejuv::flight_io
