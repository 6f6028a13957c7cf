// The MAVLink 2 messages of the ground link (common dialect, https://mavlink.io/en/messages/common.html) and
// their codec: typed structs, encode() to one frame (trailing zeros of the payload truncated, optionally
// signed) and decode() of one datagram into a typed message (decode-then-invoke: every malformed frame is a
// DecodeError with its reason; nothing is half-decoded).
//
// Each struct lists its fields in wire order (the XML's order sorted by type size, largest first, then the
// extension fields in XML order: spec "Field Reordering"). CRC_EXTRA is computed from that list as the spec
// defines it ("CRC_EXTRA Calculation": CRC-16/MCRF4XX over "NAME " and, for each non-extension field in wire
// order, "type " "name " and the array length byte if any; then low byte XOR high byte) and checked at
// compile time against the value the spec's XML yields (kSpecCrcExtra), so a mistyped field cannot build.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>

#include "rejuv/core/result.hpp"
#include "rejuv/mavlink/frame.hpp"

namespace rejuv::mavlink {

// Enumerations of the common dialect used here (values from the spec).
inline constexpr std::uint8_t kMavTypeQuadrotor = 2;        // MAV_TYPE_QUADROTOR
inline constexpr std::uint8_t kMavTypeGcs = 6;              // MAV_TYPE_GCS
inline constexpr std::uint8_t kMavAutopilotGeneric = 0;     // MAV_AUTOPILOT_GENERIC
inline constexpr std::uint8_t kMavAutopilotInvalid = 8;     // MAV_AUTOPILOT_INVALID (a ground station)
inline constexpr std::uint8_t kModeFlagCustomModeEnabled = 1;  // MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
inline constexpr std::uint8_t kModeFlagAutoEnabled = 4;        // MAV_MODE_FLAG_AUTO_ENABLED
inline constexpr std::uint8_t kModeFlagSafetyArmed = 128;      // MAV_MODE_FLAG_SAFETY_ARMED
inline constexpr std::uint8_t kMavStateActive = 4;          // MAV_STATE_ACTIVE
inline constexpr std::uint8_t kMavFrameLocalNed = 1;        // MAV_FRAME_LOCAL_NED
inline constexpr std::uint16_t kMavCmdNavWaypoint = 16;     // MAV_CMD_NAV_WAYPOINT
inline constexpr std::uint8_t kMissionTypeMission = 0;      // MAV_MISSION_TYPE_MISSION

// MAV_MISSION_RESULT (MISSION_ACK.type).
enum class MissionResult : std::uint8_t {
  Accepted = 0,
  Error = 1,
  UnsupportedFrame = 2,
  Unsupported = 3,
  NoSpace = 4,
  Invalid = 5,
  InvalidParam1 = 6,
  InvalidParam2 = 7,
  InvalidParam3 = 8,
  InvalidParam4 = 9,
  InvalidParam5X = 10,
  InvalidParam6Y = 11,
  InvalidParam7 = 12,
  InvalidSequence = 13,
  Denied = 14,
  OperationCancelled = 15,
};
[[nodiscard]] std::string_view to_string(MissionResult result);

// MAV_SEVERITY (STATUSTEXT.severity), RFC 5424.
enum class Severity : std::uint8_t { Emergency = 0, Alert, Critical, Error, Warning, Notice, Info, Debug };

struct Heartbeat {
  static constexpr std::uint32_t kId = 0;
  static constexpr std::string_view kName = "HEARTBEAT";
  static constexpr std::size_t kBaseFields = 6;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 50;
  std::uint32_t custom_mode{};
  std::uint8_t type{};
  std::uint8_t autopilot{};
  std::uint8_t base_mode{};
  std::uint8_t system_status{};
  std::uint8_t mavlink_version{3};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("custom_mode", m.custom_mode);
    f("type", m.type);
    f("autopilot", m.autopilot);
    f("base_mode", m.base_mode);
    f("system_status", m.system_status);
    f("mavlink_version", m.mavlink_version);
  }
  friend bool operator==(const Heartbeat&, const Heartbeat&) = default;
};

struct SysStatus {
  static constexpr std::uint32_t kId = 1;
  static constexpr std::string_view kName = "SYS_STATUS";
  static constexpr std::size_t kBaseFields = 13;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 124;
  std::uint32_t onboard_control_sensors_present{};
  std::uint32_t onboard_control_sensors_enabled{};
  std::uint32_t onboard_control_sensors_health{};
  std::uint16_t load{};
  std::uint16_t voltage_battery{};
  std::int16_t current_battery{};
  std::uint16_t drop_rate_comm{};
  std::uint16_t errors_comm{};
  std::uint16_t errors_count1{};
  std::uint16_t errors_count2{};
  std::uint16_t errors_count3{};
  std::uint16_t errors_count4{};
  std::int8_t battery_remaining{};
  std::uint32_t onboard_control_sensors_present_extended{};
  std::uint32_t onboard_control_sensors_enabled_extended{};
  std::uint32_t onboard_control_sensors_health_extended{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("onboard_control_sensors_present", m.onboard_control_sensors_present);
    f("onboard_control_sensors_enabled", m.onboard_control_sensors_enabled);
    f("onboard_control_sensors_health", m.onboard_control_sensors_health);
    f("load", m.load);
    f("voltage_battery", m.voltage_battery);
    f("current_battery", m.current_battery);
    f("drop_rate_comm", m.drop_rate_comm);
    f("errors_comm", m.errors_comm);
    f("errors_count1", m.errors_count1);
    f("errors_count2", m.errors_count2);
    f("errors_count3", m.errors_count3);
    f("errors_count4", m.errors_count4);
    f("battery_remaining", m.battery_remaining);
    f("onboard_control_sensors_present_extended", m.onboard_control_sensors_present_extended);
    f("onboard_control_sensors_enabled_extended", m.onboard_control_sensors_enabled_extended);
    f("onboard_control_sensors_health_extended", m.onboard_control_sensors_health_extended);
  }
  friend bool operator==(const SysStatus&, const SysStatus&) = default;
};

struct Attitude {
  static constexpr std::uint32_t kId = 30;
  static constexpr std::string_view kName = "ATTITUDE";
  static constexpr std::size_t kBaseFields = 7;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 39;
  std::uint32_t time_boot_ms{};
  float roll{};
  float pitch{};
  float yaw{};
  float rollspeed{};
  float pitchspeed{};
  float yawspeed{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("time_boot_ms", m.time_boot_ms);
    f("roll", m.roll);
    f("pitch", m.pitch);
    f("yaw", m.yaw);
    f("rollspeed", m.rollspeed);
    f("pitchspeed", m.pitchspeed);
    f("yawspeed", m.yawspeed);
  }
  friend bool operator==(const Attitude&, const Attitude&) = default;
};

struct LocalPositionNed {
  static constexpr std::uint32_t kId = 32;
  static constexpr std::string_view kName = "LOCAL_POSITION_NED";
  static constexpr std::size_t kBaseFields = 7;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 185;
  std::uint32_t time_boot_ms{};
  float x{};
  float y{};
  float z{};
  float vx{};
  float vy{};
  float vz{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("time_boot_ms", m.time_boot_ms);
    f("x", m.x);
    f("y", m.y);
    f("z", m.z);
    f("vx", m.vx);
    f("vy", m.vy);
    f("vz", m.vz);
  }
  friend bool operator==(const LocalPositionNed&, const LocalPositionNed&) = default;
};

struct GlobalPositionInt {
  static constexpr std::uint32_t kId = 33;
  static constexpr std::string_view kName = "GLOBAL_POSITION_INT";
  static constexpr std::size_t kBaseFields = 9;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 104;
  std::uint32_t time_boot_ms{};
  std::int32_t lat{};
  std::int32_t lon{};
  std::int32_t alt{};
  std::int32_t relative_alt{};
  std::int16_t vx{};
  std::int16_t vy{};
  std::int16_t vz{};
  std::uint16_t hdg{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("time_boot_ms", m.time_boot_ms);
    f("lat", m.lat);
    f("lon", m.lon);
    f("alt", m.alt);
    f("relative_alt", m.relative_alt);
    f("vx", m.vx);
    f("vy", m.vy);
    f("vz", m.vz);
    f("hdg", m.hdg);
  }
  friend bool operator==(const GlobalPositionInt&, const GlobalPositionInt&) = default;
};

struct MissionRequestList {
  static constexpr std::uint32_t kId = 43;
  static constexpr std::string_view kName = "MISSION_REQUEST_LIST";
  static constexpr std::size_t kBaseFields = 2;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 132;
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t mission_type{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("mission_type", m.mission_type);
  }
  friend bool operator==(const MissionRequestList&, const MissionRequestList&) = default;
};

struct MissionCount {
  static constexpr std::uint32_t kId = 44;
  static constexpr std::string_view kName = "MISSION_COUNT";
  static constexpr std::size_t kBaseFields = 3;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 221;
  std::uint16_t count{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t mission_type{};
  std::uint32_t opaque_id{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("count", m.count);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("mission_type", m.mission_type);
    f("opaque_id", m.opaque_id);
  }
  friend bool operator==(const MissionCount&, const MissionCount&) = default;
};

struct MissionClearAll {
  static constexpr std::uint32_t kId = 45;
  static constexpr std::string_view kName = "MISSION_CLEAR_ALL";
  static constexpr std::size_t kBaseFields = 2;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 232;
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t mission_type{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("mission_type", m.mission_type);
  }
  friend bool operator==(const MissionClearAll&, const MissionClearAll&) = default;
};

struct MissionItemReached {
  static constexpr std::uint32_t kId = 46;
  static constexpr std::string_view kName = "MISSION_ITEM_REACHED";
  static constexpr std::size_t kBaseFields = 1;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 11;
  std::uint16_t seq{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("seq", m.seq);
  }
  friend bool operator==(const MissionItemReached&, const MissionItemReached&) = default;
};

struct MissionAck {
  static constexpr std::uint32_t kId = 47;
  static constexpr std::string_view kName = "MISSION_ACK";
  static constexpr std::size_t kBaseFields = 3;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 153;
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t type{};
  std::uint8_t mission_type{};
  std::uint32_t opaque_id{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("type", m.type);
    f("mission_type", m.mission_type);
    f("opaque_id", m.opaque_id);
  }
  friend bool operator==(const MissionAck&, const MissionAck&) = default;
};

struct MissionCurrent {
  static constexpr std::uint32_t kId = 42;
  static constexpr std::string_view kName = "MISSION_CURRENT";
  static constexpr std::size_t kBaseFields = 1;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 28;
  std::uint16_t seq{};
  std::uint16_t total{};
  std::uint8_t mission_state{};
  std::uint8_t mission_mode{};
  std::uint32_t mission_id{};
  std::uint32_t fence_id{};
  std::uint32_t rally_points_id{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("seq", m.seq);
    f("total", m.total);
    f("mission_state", m.mission_state);
    f("mission_mode", m.mission_mode);
    f("mission_id", m.mission_id);
    f("fence_id", m.fence_id);
    f("rally_points_id", m.rally_points_id);
  }
  friend bool operator==(const MissionCurrent&, const MissionCurrent&) = default;
};

struct MissionRequestInt {
  static constexpr std::uint32_t kId = 51;
  static constexpr std::string_view kName = "MISSION_REQUEST_INT";
  static constexpr std::size_t kBaseFields = 3;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 196;
  std::uint16_t seq{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t mission_type{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("seq", m.seq);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("mission_type", m.mission_type);
  }
  friend bool operator==(const MissionRequestInt&, const MissionRequestInt&) = default;
};

struct MissionItemInt {
  static constexpr std::uint32_t kId = 73;
  static constexpr std::string_view kName = "MISSION_ITEM_INT";
  static constexpr std::size_t kBaseFields = 14;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 38;
  float param1{};
  float param2{};
  float param3{};
  float param4{};
  std::int32_t x{};
  std::int32_t y{};
  float z{};
  std::uint16_t seq{};
  std::uint16_t command{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t frame{};
  std::uint8_t current{};
  std::uint8_t autocontinue{};
  std::uint8_t mission_type{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("param1", m.param1);
    f("param2", m.param2);
    f("param3", m.param3);
    f("param4", m.param4);
    f("x", m.x);
    f("y", m.y);
    f("z", m.z);
    f("seq", m.seq);
    f("command", m.command);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("frame", m.frame);
    f("current", m.current);
    f("autocontinue", m.autocontinue);
    f("mission_type", m.mission_type);
  }
  friend bool operator==(const MissionItemInt&, const MissionItemInt&) = default;
};

struct StatusText {
  static constexpr std::uint32_t kId = 253;
  static constexpr std::string_view kName = "STATUSTEXT";
  static constexpr std::size_t kBaseFields = 2;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 83;
  std::uint8_t severity{};
  std::array<char, 50> text{};
  std::uint16_t id{};
  std::uint8_t chunk_seq{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("severity", m.severity);
    f("text", m.text);
    f("id", m.id);
    f("chunk_seq", m.chunk_seq);
  }
  friend bool operator==(const StatusText&, const StatusText&) = default;
};
using Message = std::variant<Heartbeat, SysStatus, Attitude, LocalPositionNed, GlobalPositionInt, MissionRequestList,
                             MissionCount, MissionClearAll, MissionItemReached, MissionAck, MissionCurrent,
                             MissionRequestInt, MissionItemInt, StatusText>;

namespace detail {
template <class T>
struct FieldType;
template <> struct FieldType<std::uint8_t> { static constexpr std::string_view kName = "uint8_t"; };
template <> struct FieldType<std::int8_t> { static constexpr std::string_view kName = "int8_t"; };
template <> struct FieldType<std::uint16_t> { static constexpr std::string_view kName = "uint16_t"; };
template <> struct FieldType<std::int16_t> { static constexpr std::string_view kName = "int16_t"; };
template <> struct FieldType<std::uint32_t> { static constexpr std::string_view kName = "uint32_t"; };
template <> struct FieldType<std::int32_t> { static constexpr std::string_view kName = "int32_t"; };
template <> struct FieldType<float> { static constexpr std::string_view kName = "float"; };
template <std::size_t N> struct FieldType<std::array<char, N>> { static constexpr std::string_view kName = "char"; };

constexpr void add_text(Crc16& crc, std::string_view text) {
  for (const char c : text) crc.add(static_cast<std::uint8_t>(c));
  crc.add(static_cast<std::uint8_t>(' '));
}
}  // namespace detail

// The payload size of M with all its fields, extensions included [bytes].
template <class M>
constexpr std::size_t payload_bytes() {
  std::size_t n = 0;
  M m{};
  M::each(m, [&](std::string_view, const auto& v) { n += sizeof(v); });
  return n;
}

// CRC_EXTRA of M, computed as the spec defines it.
template <class M>
constexpr std::uint8_t crc_extra() {
  Crc16 crc;
  detail::add_text(crc, M::kName);
  std::size_t i = 0;
  M m{};
  M::each(m, [&](std::string_view name, const auto& v) {
    using T = std::remove_cvref_t<decltype(v)>;
    if (i++ >= M::kBaseFields) return;
    detail::add_text(crc, detail::FieldType<T>::kName);
    detail::add_text(crc, name);
    if constexpr (!std::is_arithmetic_v<T>) crc.add(static_cast<std::uint8_t>(std::tuple_size_v<T>));
  });
  return static_cast<std::uint8_t>((crc.value() & 0xFFU) ^ (crc.value() >> 8U));
}

[[nodiscard]] std::uint32_t id_of(const Message& message);
[[nodiscard]] std::string_view name_of(const Message& message);
// CRC_EXTRA of a message id this codec knows (nullopt: unknown).
[[nodiscard]] std::optional<std::uint8_t> crc_extra_of(std::uint32_t msgid);

// An encoded frame (one datagram).
struct Frame {
  std::array<std::byte, kMaxFrameBytes> bytes{};
  std::size_t size = 0;
  [[nodiscard]] std::span<const std::byte> view() const { return {bytes.data(), size}; }
};

// Who sends the frame (MAVLink "system" and "component") and its sequence number.
struct Envelope {
  std::uint8_t seq = 0;
  std::uint8_t sysid = 1;
  std::uint8_t compid = 1;
};
// What signs a frame: the key, the link id and the timestamp (a sender stamps from its wall clock,
// SigningClock::now(), one tick more than its last frame when that is later: strictly increasing per stream).
struct Signer {
  SigningKey key{};
  std::uint8_t link_id = 0;
  SigningTime timestamp{};
};

[[nodiscard]] Frame encode(const Message& message, const Envelope& envelope,
                           const std::optional<Signer>& signer = std::nullopt);

// Why a datagram is not a message (the first check that failed).
enum class DecodeError : std::uint8_t {
  TooShort,          // shorter than a header and checksum
  TooLong,           // longer than the largest frame
  BadStart,          // not 0xFD
  BadIncompatFlags,  // an incompat flag other than "signed"
  BadLength,         // the datagram's size disagrees with the payload length (and the signed flag)
  UnknownMessage,    // a message id this codec does not know
  PayloadTooLong,    // longer than the message (with its extensions)
  BadChecksum,       // CRC-16/MCRF4XX with the message's CRC_EXTRA does not match
};
inline constexpr std::size_t kDecodeErrorCount = 8;
[[nodiscard]] std::string_view to_string(DecodeError error);

// A decoded frame. The signature is reported, not checked: the kernel's network gate checks it (frame.hpp).
struct Packet {
  FrameHeader header{};
  Message message{};
  std::optional<Signature> signature{};
};
[[nodiscard]] Result<Packet, DecodeError> decode(std::span<const std::byte> datagram);

// STATUSTEXT's text as a string (up to 50 characters, NUL-terminated when shorter) and back (cut at 50).
[[nodiscard]] std::string text_of(const StatusText& status);
[[nodiscard]] StatusText status_text(Severity severity, std::string_view text);

}  // namespace rejuv::mavlink
