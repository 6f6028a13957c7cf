// The `ext_link` service (docs/design.md §2, §4 `lateral`; paper §IV-D): the vehicle's end of the ground link, the
// only network-facing service. It holds the Network cap `ext_net` (RW, in MC only: the kernel's network
// gate relays nothing to it and refuses its sends in the secure execution interval) and speaks MAVLink 2
// (kernel_sim/mavlink; docs/mavlink.md) as system 1, component 1 (MAV_COMP_ID_AUTOPILOT1).
//
//   ground → HEARTBEAT, anything valid   the ground station is there: the kernel's gate sends to the source
//                           of the last datagram judged valid; that address is kernel state and survives the
//                           rollbacks that wipe what ext_link itself learned in MC.
//   ground → MISSION_COUNT … MISSION_ITEM_INT   the mission upload (mission.hpp): each item requested with
//                           MISSION_REQUEST_INT; when the last one has come, the whole mission is judged by
//                           flight_io::validate_upload — the check commander applies, with the same params —
//                           and either published on mission_upload (DATA: commander validates it again) and
//                           acknowledged MAV_MISSION_ACCEPTED, or refused with the protocol's error code. A
//                           partly received mission is never published. An item when no upload is in
//                           progress (a rollback wiped it) is answered MAV_MISSION_INVALID_SEQUENCE, and the
//                           ground station starts again.
//   ground → MISSION_REQUEST_LIST … MISSION_REQUEST_INT   the download: MISSION_COUNT, then each item asked for,
//                           of the mission flown (the upload commander kept, else the launch graph's mission),
//                           in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT given a home on Earth, else LOCAL_NED.
//   ground → MISSION_CLEAR_ALL (or MISSION_COUNT 0)   the vehicle holds: a one-waypoint mission at the current
//                           setpoint x_sp published on mission_upload, through commander's checks, and
//                           MAV_MISSION_ACCEPTED once published (a download then returns that one item); fence and
//                           rally: MAV_MISSION_ACCEPTED (there are none).
//   ground → MISSION_SET_CURRENT        MISSION_CURRENT unchanged (the path is flown in order) and a STATUSTEXT
//   ground → COMMAND_LONG / COMMAND_INT COMMAND_ACK (commands()); MAV_CMD_NAV_RETURN_TO_LAUNCH is published as a
//                           one-waypoint mission to home on mission_upload, through commander's checks.
//   ground → PARAM_REQUEST_LIST / _READ / PARAM_SET   PARAM_VALUE from params(): the launch values the ground
//                           may want (mission, geofence, home, telemetry, the SR scheme's); every one is read-only.
//   (timer)                 HEARTBEAT, SYS_STATUS, MISSION_CURRENT at 1 Hz; LOCAL_POSITION_NED and ATTITUDE
//                           every telemetry_period (and GLOBAL_POSITION_INT, given a home on Earth);
//                           MISSION_ITEM_REACHED when the setpoint moves on; STATUSTEXT for SR mode changes, rollbacks and security
//                           events seen (in any mode; sent in the next MC window).
//   anything else           refused (not MAVLink 2, bad checksum, unknown message), counted by reason, logged
//                           rate-limited; never a crash, never an effect.
//
// This class is the logic without the SDK (tests/unit/services/ext_link_test.cpp); main.cpp is the glue.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight_io/mission_record.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/mavlink/mission.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::services {

inline constexpr std::uint8_t kVehicleSystem = 1;
inline constexpr std::uint8_t kVehicleComponent = 1;  // MAV_COMP_ID_AUTOPILOT1
inline constexpr std::size_t kMaxUploadWaypoints = 16;  // idl/control.idl MissionWaypoints.waypoints[16]
inline constexpr double kDefaultAcceptanceRadius_m = 0.05;

// HEARTBEAT.custom_mode: bits 0–7 the SR mode (MC 0, RB 1, SC 2, UPDATE 3, CP 4), bits 8–31 the rollback
// epoch modulo 2²⁴ (docs/mavlink.md).
[[nodiscard]] std::uint32_t custom_mode_of(SrMode mode, Epoch epoch);

class ExtLink {
 public:
  struct UploadGuard {
    flight::PathWaypoint home{};  // the launch graph's first waypoint
    flight_io::UploadBounds bounds{};
  };
  ExtLink(UploadGuard guard, flight_io::MissionSpec launch_mission)
      : guard_(std::move(guard)), launch_mission_(std::move(launch_mission)) {
    rebuild_params();
  }

  // Where home (the local frame's origin) is on Earth: ext_link's params `home_lat_deg`, `home_lon_deg`
  // (WGS-84 [deg]) and `home_alt_m` (AMSL [m], default 0); the shipped graphs give PX4 SITL's. Without them no
  // GLOBAL_POSITION_INT, GPS_RAW_INT or HOME_POSITION is sent and items in global frames are refused.
  using GeoHome = mavlink::GeoHome;
  void set_home(const GeoHome& home) {
    home_ = home;
    rebuild_params();
  }
  [[nodiscard]] const std::optional<GeoHome>& home() const { return home_; }
  // The upload commander kept (the Persistent cell uploaded_mission, read by main.cpp in MC): what the vehicle
  // flies from the next setpoint update on, after the setpoint it had then. nullopt: none (the launch mission).
  void set_kept_upload(std::optional<flight_io::MissionSpec> kept) { kept_ = std::move(kept); }
  // The latest setpoint x_sp (main.cpp, before each datagram; telemetry() too): where a clear holds.
  void observe_setpoint(const rejuv_msg_Setpoint& setpoint);

  // One parameter of the parameter protocol: a PX4-style name (≤ 16 characters) and the launch value it shows
  // (docs/mavlink.md "Parameters"), a float or an integer. None is settable in flight.
  struct Param {
    std::string name;
    std::variant<float, std::int32_t> value{0.0F};
    // MAV_PARAM_TYPE: REAL32 (9) for a float, INT32 (6) for an integer.
    [[nodiscard]] std::uint8_t type() const;
    // PARAM_VALUE.param_value: a float as it is, an integer's four bytes as they are (PX4's
    // MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE, mavlink.io "Parameter Protocol", "Parameter Encoding").
    [[nodiscard]] float wire_value() const;
  };
  [[nodiscard]] const std::vector<Param>& params() const { return params_; }
  // The SR scheme's graph-wide values (rejuv/core/graph_values.hpp) as the kernel passed them to ext_link (each
  // key's default where it passed none), listed as the RJ_SR_* params; a value outside its key's range is
  // refused, naming the key. With SR off only RJ_SR_ENABLED (0) is listed: the others act on nothing. Without
  // this call (a unit test's ExtLink) no RJ_SR_* param is listed.
  [[nodiscard]] Result<void, flight_io::InputFailure> set_sr_values(const flight_io::Params& params);
  void set_telemetry_period(double period_s);
  [[nodiscard]] static Result<ExtLink, flight_io::InputFailure> from_params(const flight_io::Params& params);

  // What a Forward carries out: a mission uploaded, a clear (hold at the setpoint), a return to launch.
  enum class Request : std::uint8_t { Upload, Clear, ReturnToLaunch };
  // A mission that passed validate_upload: publish it, then acknowledge with forwarded() (MISSION_ACK of
  // `mission_type` for an upload or a clear, COMMAND_ACK for RTL).
  struct Forward {
    rejuv_msg_MissionWaypoints upload{};
    std::vector<mavlink::LocalWaypoint> waypoints{};
    std::uint8_t ground_system = 0;
    std::uint8_t ground_component = 0;
    Request request = Request::Upload;
    std::uint8_t mission_type = mavlink::kMissionTypeMission;  // a clear of MAV_MISSION_TYPE_ALL is acked as such
  };
  // What one valid datagram asks for: frames to send back, maybe a mission to publish, maybe a log line.
  struct Inbound {
    std::vector<mavlink::Message> replies{};
    std::optional<Forward> forward{};
    std::optional<std::string> note{};
  };
  [[nodiscard]] Result<Inbound, mavlink::DecodeError> on_datagram(std::span<const std::byte> datagram, Nanos now);
  // The upload of `forward` was published: remember it and build its MAV_MISSION_ACCEPTED.
  [[nodiscard]] mavlink::Message forwarded(const Forward& forward);
  // It could not be published: the upload is dropped (the ground station times out and starts again).
  void abandon();
  // The frame of a message this vehicle sends (its sequence number counts up).
  [[nodiscard]] mavlink::Frame frame(const mavlink::Message& message);

  // What the SR cycle and the kernel show at a timer tick (in any mode): queues STATUSTEXTs for a new mode,
  // a new epoch (a rollback) and new security events. Pending texts of an older epoch are dropped: they were
  // for the MC window a rollback has since ended (they were sent there, or nobody was listening).
  struct Observation {
    SrMode mode = SrMode::MC;
    Epoch epoch{};
    std::uint64_t security_events = 0;
    const rejuv_msg_SecurityEvent* latest_event = nullptr;
  };
  void observe(const Observation& seen);

  // What telemetry reports (the latest of each topic; absent ones are sent as zeros).
  struct TelemetryInputs {
    Nanos now{0};
    const rejuv_msg_VehicleStateEstimate* state = nullptr;
    const rejuv_msg_Setpoint* setpoint = nullptr;
    const rejuv_msg_SensorGps* gps = nullptr;  // the plant's latest GPS sample (nullptr: the graph gives none)
    SrMode mode = SrMode::MC;
    Epoch epoch{};
  };
  // The messages due at `in.now` (MC only): pending STATUSTEXTs, the 1 Hz set when a second has passed,
  // MISSION_ITEM_REACHED when the setpoint's waypoint index grew, LOCAL_POSITION_NED and ATTITUDE.
  [[nodiscard]] std::vector<mavlink::Message> telemetry(const TelemetryInputs& in);

  [[nodiscard]] std::uint64_t refused() const { return refused_total_; }
  [[nodiscard]] std::uint64_t refused(mavlink::DecodeError why) const { return refused_[static_cast<std::size_t>(why)]; }
  [[nodiscard]] std::uint64_t uploads_forwarded() const { return uploads_forwarded_; }
  [[nodiscard]] std::uint64_t uploads_refused() const { return uploads_refused_; }
  [[nodiscard]] bool upload_in_progress() const { return receiving_.has_value(); }
  [[nodiscard]] std::size_t pending_texts() const { return pending_.size(); }
  [[nodiscard]] bool should_log_refusal(Nanos now, std::uint64_t& suppressed);

  static constexpr std::size_t kMaxPendingTexts = 8;

 private:
  struct Receiving {
    std::uint16_t count = 0;
    std::uint8_t ground_system = 0;
    std::uint8_t ground_component = 0;
    double acceptance_radius_m = kDefaultAcceptanceRadius_m;
    std::vector<mavlink::LocalWaypoint> waypoints{};
  };
  struct PendingText {
    Epoch epoch{};
    mavlink::StatusText text{};
  };
  [[nodiscard]] mavlink::Message ack(std::uint8_t system, std::uint8_t component, mavlink::MissionResult result,
                                     std::uint8_t mission_type = mavlink::kMissionTypeMission) const;
  [[nodiscard]] Inbound on_count(const mavlink::FrameHeader& from, const mavlink::MissionCount& count, Nanos now);
  [[nodiscard]] Inbound on_item(const mavlink::FrameHeader& from, const mavlink::MissionItemInt& item, Nanos now);
  [[nodiscard]] Inbound on_command(const mavlink::FrameHeader& from, std::uint16_t command, std::array<float, 2> param12,
                                   Nanos now);
  [[nodiscard]] Inbound on_param(const mavlink::Message& message);
  [[nodiscard]] Inbound on_clear(const mavlink::FrameHeader& from, std::uint8_t mission_type, Nanos now);
  [[nodiscard]] mavlink::ParamValue param_value(std::size_t index) const;
  // The mission a download returns and MISSION_CURRENT counts: what this window forwarded, else the kept
  // upload, else the launch mission; and by how much the setpoint's waypoint index runs ahead of its item
  // numbers (an upload is flown after the setpoint it started from: 1).
  struct Flown {
    std::vector<mavlink::LocalWaypoint> waypoints;
    double acceptance_radius_m = kDefaultAcceptanceRadius_m;
    std::uint32_t index_offset = 0;
  };
  [[nodiscard]] Flown flown() const;
  [[nodiscard]] mavlink::Message home_position(std::uint32_t time_boot_ms) const;
  [[nodiscard]] mavlink::Message autopilot_version() const;
  void rebuild_params();
  [[nodiscard]] mavlink::SysStatus sys_status(const TelemetryInputs& in);
  // telemetry()'s 1 Hz set: HEARTBEAT, SYS_STATUS, EXTENDED_SYS_STATE, HOME_POSITION (given a home) and
  // MISSION_CURRENT (given a setpoint).
  void append_slow_set(const TelemetryInputs& in, const Flown& mission, std::uint32_t time_boot_ms,
                       std::vector<mavlink::Message>& out);
  // telemetry()'s messages of one estimate: LOCAL_POSITION_NED, GLOBAL_POSITION_INT (given a home), ATTITUDE,
  // VFR_HUD.
  void append_estimate(const rejuv_msg_VehicleStateEstimate& s, std::uint32_t time_boot_ms,
                       std::vector<mavlink::Message>& out) const;
  // The timestamps seen at the last SYS_STATUS: a sample newer than these is a sign of health.
  struct HealthSeen {
    std::uint64_t state_ns = 0;
    std::uint64_t gps_ns = 0;
    std::uint64_t setpoint_ns = 0;
  };
  HealthSeen health_seen_{};
  std::optional<std::uint64_t> last_gps_ns_{};
  void queue_text(Epoch epoch, mavlink::Severity severity, const std::string& text);

  UploadGuard guard_;
  flight_io::MissionSpec launch_mission_;
  std::optional<flight_io::MissionSpec> kept_{};
  std::optional<double> last_forwarded_radius_m_{};
  double telemetry_period_s_ = 0.1;
  std::vector<Param> sr_params_{};  // the RJ_SR_* params (set_sr_values)
  std::vector<Param> params_{};
  bool reported_done_ = false;  // MISSION_ITEM_REACHED for the last item was sent
  std::uint8_t next_seq_ = 0;
  std::optional<Receiving> receiving_{};
  std::optional<std::vector<mavlink::LocalWaypoint>> last_forwarded_{};
  std::uint64_t uploads_forwarded_ = 0;
  std::uint64_t uploads_refused_ = 0;
  std::uint64_t refused_total_ = 0;
  std::array<std::uint64_t, mavlink::kDecodeErrorCount> refused_{};
  std::optional<Nanos> last_log_{};
  std::uint64_t unlogged_ = 0;
  std::optional<Nanos> last_slow_{};  // the last 1 Hz set
  std::optional<std::uint32_t> last_waypoint_{};  // the setpoint's waypoint index at the last telemetry
  std::optional<GeoHome> home_{};
  std::optional<mavlink::LocalWaypoint> setpoint_{};  // the latest x_sp seen (a clear's hold point)
  std::optional<SrMode> seen_mode_{};
  std::optional<Epoch> seen_epoch_{};
  std::uint64_t seen_events_ = 0;
  std::deque<PendingText> pending_{};
};

// The upload as commander's topic type, stamped `now`.
[[nodiscard]] rejuv_msg_MissionWaypoints to_message(std::span<const mavlink::LocalWaypoint> waypoints,
                                                    double acceptance_radius_m, Nanos now);

}  // namespace rejuv::services
