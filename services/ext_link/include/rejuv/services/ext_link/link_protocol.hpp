// The ground link protocol (docs/link_protocol.md): what ext_link and `rejuv gcs` exchange over UDP through
// the kernel's network gate (DESIGN §2). A MAVLink-like, fixed-layout, little-endian binary datagram:
//
//   offset  size  field
//        0     4  magic        "RJLK" (0x52 0x4A 0x4C 0x4B)
//        4     1  version      kLinkVersion (1)
//        5     1  type         MessageType
//        6     2  body_length  bytes after the header; must equal the type's fixed body size
//        8     4  sequence     sender's message counter (an upload's is echoed in its MissionAck)
//       12     4  checksum     CRC-32 (IEEE 802.3, as zlib) of the whole datagram with this field zeroed
//       16     …  body         per type, below
//
// Everything the vehicle receives is untrusted: decode() checks size, magic, version, type, the body length
// of the type, the checksum, every reserved field (zero), counts and that every number is finite, and
// refuses the datagram on the first failure (no partial effects). The kernel never parses these bytes; this
// codec runs only inside ext_link (sandboxed, rolled back) and the ground tool.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <variant>

#include "rejuv/core/result.hpp"

namespace rejuv::link {

inline constexpr std::array<std::uint8_t, 4> kMagic{0x52, 0x4A, 0x4C, 0x4B};  // "RJLK"
inline constexpr std::uint8_t kLinkVersion = 1;
inline constexpr std::size_t kHeaderBytes = 16;
inline constexpr std::size_t kMaxUploadWaypoints = 16;  // idl/control.idl MissionWaypoints.waypoints[16]
inline constexpr std::size_t kMaxLinkDatagramBytes = 1400;  // = wire::kMaxDatagramBytes (the gate's limit)

enum class MessageType : std::uint8_t {
  Hello = 1,          // ground → vehicle: "send telemetry here". Body: none.
  MissionUpload = 2,  // ground → vehicle: a mission for commander. Body: MissionUpload.
  MissionAck = 3,     // vehicle → ground: the upload with this sequence was handed to commander, or refused.
  Telemetry = 4,      // vehicle → ground: state, setpoint, mode, security events (MC only, ≈10 Hz).
};
[[nodiscard]] std::string_view to_string(MessageType type);

// Which side may send a type: the vehicle accepts only ground → vehicle types and the reverse.
enum class Direction : std::uint8_t { ToVehicle, ToGround };

struct Hello {
  friend bool operator==(const Hello&, const Hello&) = default;
};

// Body: u32 count (1 … 16), u32 reserved (0), f64 acceptance_radius_m (> 0), then count × {f64 north_m,
// f64 east_m, f64 down_m, f64 yaw_rad} (local NED [m], [rad]). Body size 16 + 32·count exactly.
struct UploadWaypoint {
  double north_m = 0;
  double east_m = 0;
  double down_m = 0;  // NED: 3 m up is −3
  double yaw_rad = 0;
  friend bool operator==(const UploadWaypoint&, const UploadWaypoint&) = default;
};
struct MissionUpload {
  std::uint32_t count = 0;
  double acceptance_radius_m = 0.05;  // [m]
  std::array<UploadWaypoint, kMaxUploadWaypoints> waypoints{};
  friend bool operator==(const MissionUpload&, const MissionUpload&) = default;
};

// Body (8 bytes): u32 upload_sequence, u8 status, then
//   status 0 Forwarded: 3 reserved bytes (0) — the upload passed the check commander applies and was handed
//                       to it (version 1's only status: such an ack is unchanged);
//   status 1 Refused:   u8 reason (RefusalReason, 1 … 4), u16 waypoint (the index in the upload of the
//                       waypoint at fault, 0 … 15; 0 when the reason names no waypoint).
enum class AckStatus : std::uint8_t { Forwarded = 0, Refused = 1 };
// Why ext_link refused a well-formed upload (flight_io::validate_upload, the check commander applies).
enum class RefusalReason : std::uint8_t {
  None = 0,                // Forwarded
  InvalidMission = 1,      // not a mission the flight services accept (e.g. an acceptance radius they refuse)
  TooManyWaypoints = 2,    // more than 15 (the path flown starts at the current setpoint)
  OutsideGeofence = 3,     // a waypoint farther from home horizontally than the geofence radius
  BelowAltitudeFloor = 4,  // a waypoint below the altitude floor
};
inline constexpr std::uint8_t kMaxRefusalReason = 4;
[[nodiscard]] std::string_view to_string(RefusalReason reason);
struct MissionAck {
  std::uint32_t upload_sequence = 0;
  AckStatus status = AckStatus::Forwarded;
  RefusalReason reason = RefusalReason::None;  // None iff Forwarded
  std::uint16_t waypoint = 0;                  // Refused: the waypoint at fault (0 when none is)
  friend bool operator==(const MissionAck&, const MissionAck&) = default;
};

// Body (128 bytes): u64 time_ns (kernel clock), f64 p_N_m[3], f64 v_N_m_s[3] (estimate x̂), f64
// setpoint_N_m[3], f64 setpoint_yaw_rad, u32 waypoint_index, u8 sr_mode (rejuv::SrMode index: MC 0, RB 1,
// SC 2, UPDATE 3, CP 4), u8 mission_done, u16 reserved (0), u32 epoch, u32 reserved (0), u64
// security_events (denials the kernel reported), u64 link_refused (datagrams ext_link refused), u64
// uploads_forwarded. Numbers are the vehicle's as they are (a diverged estimate shows as NaN).
struct Telemetry {
  std::uint64_t time_ns = 0;
  std::array<double, 3> p_N_m{};
  std::array<double, 3> v_N_m_s{};
  std::array<double, 3> setpoint_N_m{};
  double setpoint_yaw_rad = 0;
  std::uint32_t waypoint_index = 0;
  std::uint8_t sr_mode = 0;
  std::uint8_t mission_done = 0;
  std::uint32_t epoch = 0;
  std::uint64_t security_events = 0;
  std::uint64_t link_refused = 0;
  std::uint64_t uploads_forwarded = 0;
  friend bool operator==(const Telemetry&, const Telemetry&) = default;
};

using Body = std::variant<Hello, MissionUpload, MissionAck, Telemetry>;
struct Message {
  std::uint32_t sequence = 0;
  Body body{};
  friend bool operator==(const Message&, const Message&) = default;
};
[[nodiscard]] MessageType type_of(const Body& body);
[[nodiscard]] Direction direction_of(MessageType type);

// Why a datagram was refused (one reason, the first check that failed).
enum class DecodeError : std::uint8_t {
  TooShort,        // shorter than the header
  TooLong,         // longer than kMaxLinkDatagramBytes
  BadMagic,
  BadVersion,
  UnknownType,
  WrongDirection,  // a vehicle → ground type sent to the vehicle (or the reverse)
  BadLength,       // body_length disagrees with the datagram or with the type's body size
  BadChecksum,
  BadReserved,     // a reserved field is not zero
  BadCount,        // waypoint count outside 1 … 16
  NonFinite,       // NaN or infinity where a number must be finite
  OutOfRange,      // e.g. acceptance radius ≤ 0, unknown ack status, refusal reason or mode
};
inline constexpr std::size_t kDecodeErrorCount = 12;
[[nodiscard]] std::string_view to_string(DecodeError error);

// An encoded datagram (never larger than kMaxLinkDatagramBytes).
struct Datagram {
  std::array<std::byte, kMaxLinkDatagramBytes> bytes{};
  std::size_t size = 0;
  [[nodiscard]] std::span<const std::byte> view() const { return {bytes.data(), size}; }
};

// Encodes `message`. Precondition (REJUV_ASSERT): an upload's count is 0 … 16 (decode refuses 0).
[[nodiscard]] Datagram encode(const Message& message);
// Decodes a datagram that `expected` says this side may receive; refuses anything else.
[[nodiscard]] Result<Message, DecodeError> decode(std::span<const std::byte> datagram, Direction expected);

// CRC-32 (IEEE 802.3 polynomial, reflected, init and final xor 0xFFFFFFFF: zlib's crc32).
[[nodiscard]] std::uint32_t crc32(std::span<const std::byte> bytes);

}  // namespace rejuv::link
