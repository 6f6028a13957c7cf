// The `ext_link` service (DESIGN §2, §4 `lateral`; paper §IV-D): the vehicle's end of the ground link, the
// only network-facing service. It holds the Network cap `ext_net` (RW, in MC only: the kernel's network
// gate relays nothing to it and refuses its sends in the secure execution interval) and speaks the link
// protocol of link_protocol.hpp (docs/link_protocol.md).
//
//   ground → Hello          the ground station is there. The kernel's gate remembers the source of the last
//                           relayed datagram and sends there; that address is kernel state and survives
//                           the rollbacks that wipe what ext_link itself learned in MC.
//   (timer)                 Telemetry every telemetry_period, in MC only (refused by the kernel, quietly,
//                           while no ground station has spoken).
//   ground → MissionUpload  decoded and range-checked, then judged by flight_io::validate_upload — the check
//                           commander applies (count, geofence around home, altitude floor), with the same
//                           params — and either published on mission_upload (DATA: commander validates it
//                           again before keeping it) and acknowledged with a MissionAck Forwarded, or answered
//                           with a MissionAck Refused that names the reason and the waypoint at fault, and
//                           not published. A retransmission of the upload just forwarded is acknowledged
//                           again, not republished; a refused one is refused again.
//   anything else           refused, counted by reason, logged rate-limited; never a crash, never an effect.
//
// Topics: in vehicle_state, setpoint, sr_mode, security_event (telemetry); out mission_upload (MC only).
// Params: `telemetry_period_s` (default 0.1: 10 Hz; 0.01 … 10); the launch graph's mission (home is its
// first waypoint) and `geofence.radius_m`, `geofence.min_altitude_m` as commander reads them
// (flight_io::upload_bounds: set them on both services, or neither).
//
// This class is the logic without the SDK (tests/unit/services/ext_link_test.cpp); main.cpp is the glue.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <variant>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight_io/mission_record.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/services/ext_link/link_protocol.hpp"

namespace rejuv::services {

class ExtLink {
 public:
  // What an upload must pass to be forwarded (commander's check: flight_io::validate_upload).
  struct UploadGuard {
    flight::PathWaypoint home{};  // the launch graph's first waypoint
    flight_io::UploadBounds bounds{};
  };
  explicit ExtLink(UploadGuard guard) : guard_(std::move(guard)) {}
  // From the service's params: the launch graph's mission (its first waypoint is home) and geofence.*.
  [[nodiscard]] static Result<ExtLink, flight_io::InputFailure> from_params(const flight_io::Params& params);

  // A decoded upload to publish on mission_upload, then acknowledge.
  struct Forward {
    rejuv_msg_MissionWaypoints upload{};  // what to publish
    link::MissionUpload decoded{};        // as it came
    std::uint32_t sequence = 0;
  };
  // A retransmission of the upload already forwarded: acknowledge it again, publish nothing.
  struct Reacknowledge {
    std::uint32_t sequence = 0;
  };
  // A well-formed upload that validate_upload refuses: answer with a negative acknowledgement, publish nothing.
  struct Refuse {
    std::uint32_t sequence = 0;
    link::RefusalReason reason = link::RefusalReason::InvalidMission;
    std::uint16_t waypoint = 0;  // in the upload, when the reason names one
    std::string message{};       // for the log
  };
  // A Hello: the ground station wants telemetry.
  struct GroundHello {};
  using Inbound = std::variant<GroundHello, Forward, Reacknowledge, Refuse>;

  // One datagram relayed by the gate (untrusted bytes). A refusal is counted by reason.
  [[nodiscard]] Result<Inbound, link::DecodeError> on_datagram(std::span<const std::byte> datagram, Nanos now);
  // The upload of `forward` was published: remember it and build its MissionAck.
  [[nodiscard]] link::Datagram forwarded(const Forward& forward);
  // The MissionAck of a retransmission.
  [[nodiscard]] link::Datagram acknowledge(std::uint32_t upload_sequence);
  // The negative MissionAck (status Refused, the reason and the waypoint) of `refuse`; counts it.
  [[nodiscard]] link::Datagram refused_upload(const Refuse& refuse);

  // What telemetry reports (the latest of each topic; absent ones are sent as zeros).
  struct TelemetryInputs {
    Nanos now{0};
    const rejuv_msg_VehicleStateEstimate* state = nullptr;
    const rejuv_msg_Setpoint* setpoint = nullptr;
    SrMode mode = SrMode::MC;
    Epoch epoch{};
    std::uint64_t security_events = 0;
  };
  [[nodiscard]] link::Datagram telemetry(const TelemetryInputs& in);

  // Whether a ground station has said Hello or uploaded since this incarnation's checkpoint (informational).
  [[nodiscard]] bool ground_known() const { return ground_known_; }
  [[nodiscard]] std::uint64_t refused() const { return refused_total_; }
  [[nodiscard]] std::uint64_t refused(link::DecodeError why) const { return refused_[static_cast<std::size_t>(why)]; }
  [[nodiscard]] std::uint64_t uploads_forwarded() const { return uploads_forwarded_; }
  [[nodiscard]] std::uint64_t uploads_refused() const { return uploads_refused_; }
  // Rate limit of refusal log lines on the kernel clock: true at most once per second; `suppressed` is how
  // many refusals were not logged since the last line.
  [[nodiscard]] bool should_log_refusal(Nanos now, std::uint64_t& suppressed);

 private:
  UploadGuard guard_;
  std::uint32_t next_sequence_ = 1;
  bool ground_known_ = false;
  std::optional<link::MissionUpload> last_upload_{};
  std::uint32_t last_upload_sequence_ = 0;
  std::uint64_t uploads_forwarded_ = 0;
  std::uint64_t uploads_refused_ = 0;
  std::uint64_t refused_total_ = 0;
  std::array<std::uint64_t, link::kDecodeErrorCount> refused_{};
  std::optional<Nanos> last_log_{};
  std::uint64_t unlogged_ = 0;
};

// The upload as commander's topic type, stamped `now`.
[[nodiscard]] rejuv_msg_MissionWaypoints to_message(const link::MissionUpload& upload, Nanos now);

}  // namespace rejuv::services
