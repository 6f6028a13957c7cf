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
struct ParamRequestRead {
  static constexpr std::uint32_t kId = 20;
  static constexpr std::string_view kName = "PARAM_REQUEST_READ";
  static constexpr std::size_t kBaseFields = 4;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 214;
  std::int16_t param_index{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::array<char, 16> param_id{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("param_index", m.param_index);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("param_id", m.param_id);
  }
  friend bool operator==(const ParamRequestRead&, const ParamRequestRead&) = default;
};
struct ParamRequestList {
  static constexpr std::uint32_t kId = 21;
  static constexpr std::string_view kName = "PARAM_REQUEST_LIST";
  static constexpr std::size_t kBaseFields = 2;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 159;
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("target_system", m.target_system);
    f("target_component", m.target_component);
  }
  friend bool operator==(const ParamRequestList&, const ParamRequestList&) = default;
};
struct ParamValue {
  static constexpr std::uint32_t kId = 22;
  static constexpr std::string_view kName = "PARAM_VALUE";
  static constexpr std::size_t kBaseFields = 5;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 220;
  float param_value{};
  std::uint16_t param_count{};
  std::uint16_t param_index{};
  std::array<char, 16> param_id{};
  std::uint8_t param_type{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("param_value", m.param_value);
    f("param_count", m.param_count);
    f("param_index", m.param_index);
    f("param_id", m.param_id);
    f("param_type", m.param_type);
  }
  friend bool operator==(const ParamValue&, const ParamValue&) = default;
};
struct ParamSet {
  static constexpr std::uint32_t kId = 23;
  static constexpr std::string_view kName = "PARAM_SET";
  static constexpr std::size_t kBaseFields = 5;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 168;
  float param_value{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::array<char, 16> param_id{};
  std::uint8_t param_type{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("param_value", m.param_value);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("param_id", m.param_id);
    f("param_type", m.param_type);
  }
  friend bool operator==(const ParamSet&, const ParamSet&) = default;
};
struct GpsRawInt {
  static constexpr std::uint32_t kId = 24;
  static constexpr std::string_view kName = "GPS_RAW_INT";
  static constexpr std::size_t kBaseFields = 10;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 24;
  std::uint64_t time_usec{};
  std::int32_t lat{};
  std::int32_t lon{};
  std::int32_t alt{};
  std::uint16_t eph{};
  std::uint16_t epv{};
  std::uint16_t vel{};
  std::uint16_t cog{};
  std::uint8_t fix_type{};
  std::uint8_t satellites_visible{};
  std::int32_t alt_ellipsoid{};
  std::uint32_t h_acc{};
  std::uint32_t v_acc{};
  std::uint32_t vel_acc{};
  std::uint32_t hdg_acc{};
  std::uint16_t yaw{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("time_usec", m.time_usec);
    f("lat", m.lat);
    f("lon", m.lon);
    f("alt", m.alt);
    f("eph", m.eph);
    f("epv", m.epv);
    f("vel", m.vel);
    f("cog", m.cog);
    f("fix_type", m.fix_type);
    f("satellites_visible", m.satellites_visible);
    f("alt_ellipsoid", m.alt_ellipsoid);
    f("h_acc", m.h_acc);
    f("v_acc", m.v_acc);
    f("vel_acc", m.vel_acc);
    f("hdg_acc", m.hdg_acc);
    f("yaw", m.yaw);
  }
  friend bool operator==(const GpsRawInt&, const GpsRawInt&) = default;
};
struct MissionSetCurrent {
  static constexpr std::uint32_t kId = 41;
  static constexpr std::string_view kName = "MISSION_SET_CURRENT";
  static constexpr std::size_t kBaseFields = 3;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 28;
  std::uint16_t seq{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("seq", m.seq);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
  }
  friend bool operator==(const MissionSetCurrent&, const MissionSetCurrent&) = default;
};
struct VfrHud {
  static constexpr std::uint32_t kId = 74;
  static constexpr std::string_view kName = "VFR_HUD";
  static constexpr std::size_t kBaseFields = 6;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 20;
  float airspeed{};
  float groundspeed{};
  float alt{};
  float climb{};
  std::int16_t heading{};
  std::uint16_t throttle{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("airspeed", m.airspeed);
    f("groundspeed", m.groundspeed);
    f("alt", m.alt);
    f("climb", m.climb);
    f("heading", m.heading);
    f("throttle", m.throttle);
  }
  friend bool operator==(const VfrHud&, const VfrHud&) = default;
};
struct CommandInt {
  static constexpr std::uint32_t kId = 75;
  static constexpr std::string_view kName = "COMMAND_INT";
  static constexpr std::size_t kBaseFields = 13;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 158;
  float param1{};
  float param2{};
  float param3{};
  float param4{};
  std::int32_t x{};
  std::int32_t y{};
  float z{};
  std::uint16_t command{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t frame{};
  std::uint8_t current{};
  std::uint8_t autocontinue{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("param1", m.param1);
    f("param2", m.param2);
    f("param3", m.param3);
    f("param4", m.param4);
    f("x", m.x);
    f("y", m.y);
    f("z", m.z);
    f("command", m.command);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("frame", m.frame);
    f("current", m.current);
    f("autocontinue", m.autocontinue);
  }
  friend bool operator==(const CommandInt&, const CommandInt&) = default;
};
struct CommandLong {
  static constexpr std::uint32_t kId = 76;
  static constexpr std::string_view kName = "COMMAND_LONG";
  static constexpr std::size_t kBaseFields = 11;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 152;
  float param1{};
  float param2{};
  float param3{};
  float param4{};
  float param5{};
  float param6{};
  float param7{};
  std::uint16_t command{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  std::uint8_t confirmation{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("param1", m.param1);
    f("param2", m.param2);
    f("param3", m.param3);
    f("param4", m.param4);
    f("param5", m.param5);
    f("param6", m.param6);
    f("param7", m.param7);
    f("command", m.command);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
    f("confirmation", m.confirmation);
  }
  friend bool operator==(const CommandLong&, const CommandLong&) = default;
};
struct CommandAck {
  static constexpr std::uint32_t kId = 77;
  static constexpr std::string_view kName = "COMMAND_ACK";
  static constexpr std::size_t kBaseFields = 2;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 143;
  std::uint16_t command{};
  std::uint8_t result{};
  std::uint8_t progress{};
  std::int32_t result_param2{};
  std::uint8_t target_system{};
  std::uint8_t target_component{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("command", m.command);
    f("result", m.result);
    f("progress", m.progress);
    f("result_param2", m.result_param2);
    f("target_system", m.target_system);
    f("target_component", m.target_component);
  }
  friend bool operator==(const CommandAck&, const CommandAck&) = default;
};
struct AutopilotVersion {
  static constexpr std::uint32_t kId = 148;
  static constexpr std::string_view kName = "AUTOPILOT_VERSION";
  static constexpr std::size_t kBaseFields = 11;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 178;
  std::uint64_t capabilities{};
  std::uint64_t uid{};
  std::uint32_t flight_sw_version{};
  std::uint32_t middleware_sw_version{};
  std::uint32_t os_sw_version{};
  std::uint32_t board_version{};
  std::uint16_t vendor_id{};
  std::uint16_t product_id{};
  std::array<std::uint8_t, 8> flight_custom_version{};
  std::array<std::uint8_t, 8> middleware_custom_version{};
  std::array<std::uint8_t, 8> os_custom_version{};
  std::array<std::uint8_t, 18> uid2{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("capabilities", m.capabilities);
    f("uid", m.uid);
    f("flight_sw_version", m.flight_sw_version);
    f("middleware_sw_version", m.middleware_sw_version);
    f("os_sw_version", m.os_sw_version);
    f("board_version", m.board_version);
    f("vendor_id", m.vendor_id);
    f("product_id", m.product_id);
    f("flight_custom_version", m.flight_custom_version);
    f("middleware_custom_version", m.middleware_custom_version);
    f("os_custom_version", m.os_custom_version);
    f("uid2", m.uid2);
  }
  friend bool operator==(const AutopilotVersion&, const AutopilotVersion&) = default;
};
struct HomePosition {
  static constexpr std::uint32_t kId = 242;
  static constexpr std::string_view kName = "HOME_POSITION";
  static constexpr std::size_t kBaseFields = 10;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 104;
  std::int32_t latitude{};
  std::int32_t longitude{};
  std::int32_t altitude{};
  float x{};
  float y{};
  float z{};
  std::array<float, 4> q{};
  float approach_x{};
  float approach_y{};
  float approach_z{};
  std::uint64_t time_usec{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("latitude", m.latitude);
    f("longitude", m.longitude);
    f("altitude", m.altitude);
    f("x", m.x);
    f("y", m.y);
    f("z", m.z);
    f("q", m.q);
    f("approach_x", m.approach_x);
    f("approach_y", m.approach_y);
    f("approach_z", m.approach_z);
    f("time_usec", m.time_usec);
  }
  friend bool operator==(const HomePosition&, const HomePosition&) = default;
};
struct ExtendedSysState {
  static constexpr std::uint32_t kId = 245;
  static constexpr std::string_view kName = "EXTENDED_SYS_STATE";
  static constexpr std::size_t kBaseFields = 2;  // the rest are extensions (not in CRC_EXTRA)
  static constexpr std::uint8_t kSpecCrcExtra = 130;
  std::uint8_t vtol_state{};
  std::uint8_t landed_state{};
  template <class Self, class F>
  static constexpr void each(Self& m, F&& f) {
    f("vtol_state", m.vtol_state);
    f("landed_state", m.landed_state);
  }
  friend bool operator==(const ExtendedSysState&, const ExtendedSysState&) = default;
};
using Message =
    std::variant<Heartbeat, SysStatus, Attitude, LocalPositionNed, GlobalPositionInt, MissionRequestList, MissionCount,
                 MissionClearAll, MissionItemReached, MissionAck, MissionCurrent, MissionRequestInt, MissionItemInt,
                 StatusText, ParamRequestRead, ParamRequestList, ParamValue, ParamSet, GpsRawInt, MissionSetCurrent,
                 VfrHud, CommandInt, CommandLong, CommandAck, AutopilotVersion, HomePosition, ExtendedSysState>;

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
template <> struct FieldType<std::uint64_t> { static constexpr std::string_view kName = "uint64_t"; };
template <> struct FieldType<char> { static constexpr std::string_view kName = "char"; };
// An array field is named by its element type (its length follows its name in CRC_EXTRA).
template <class T, std::size_t N> struct FieldType<std::array<T, N>> { static constexpr std::string_view kName = FieldType<T>::kName; };

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

[[nodiscard]] Frame encode(const Message& message, const Envelope& envelope);
// The same, signed when `signer` is given (src/signing.cpp, with SHA-256 from libcrypto).
[[nodiscard]] Frame encode(const Message& message, const Envelope& envelope, const std::optional<Signer>& signer);

// The signed copy of an unsigned MAVLink 2 frame of a message this codec knows, its checksum checked first:
// the "signed" incompat flag set, the checksum recomputed over the new header, the signature appended (spec
// "Message Signing"). The kernel's network gate signs the vehicle's frames this way, so that the key never
// leaves the kernel. nullopt: not such a frame (malformed, signed already, unknown id, bad checksum).
[[nodiscard]] std::optional<Frame> sign_frame(std::span<const std::byte> datagram, const Signer& signer);

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
// What decode() checks before it reads the payload (the envelope, a known id, the payload's length, the
// checksum), without reading it: the frame and its message's CRC_EXTRA.
struct CheckedFrame {
  FrameView frame;
  std::uint8_t crc_extra = 0;
};
[[nodiscard]] Result<CheckedFrame, DecodeError> check_frame(std::span<const std::byte> datagram);

// STATUSTEXT's text as a string (up to 50 characters, NUL-terminated when shorter) and back (cut at 50).
[[nodiscard]] std::string text_of(const StatusText& status);
[[nodiscard]] StatusText status_text(Severity severity, std::string_view text);

}  // namespace rejuv::mavlink
