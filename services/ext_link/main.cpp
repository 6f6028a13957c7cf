// rejuv_ext_link: the vehicle's end of the ground link (services/ext_link/include/rejuv/services/ext_link/
// ext_link.hpp). No command line: started by the kernel.
#include <chrono>
#include <cmath>
#include <optional>
#include <string_view>

#include "rejuv/flight_io/messages.hpp"
#include "rejuv/flight_io/mission_record.hpp"
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/ext_link/ext_link.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

constexpr std::string_view kNet = "ext_net";

// The topics ext_link reads and writes.
struct Topics {
  sdk::Publisher<rejuv_msg_MissionWaypoints> uploads;
  sdk::Subscription<rejuv_msg_VehicleStateEstimate> state;
  sdk::Subscription<rejuv_msg_Setpoint> setpoint;
  // The SR cycle's modes and epochs, turned into STATUSTEXT (ExtLink::observe).
  sdk::Subscription<rejuv_msg_SrMode> modes;
  sdk::Subscription<rejuv_msg_SecurityEvent> events;
  // The plant's GPS samples, for GPS_RAW_INT and SYS_STATUS (optional: a graph that grants none has no GPS
  // reported).
  std::optional<sdk::Subscription<rejuv_msg_SensorGps>> gps;
};

std::optional<Topics> open_topics(sdk::Service& svc) {
  auto uploads = svc.advertise<rejuv_msg_MissionWaypoints>("mission_upload");
  if (!svc.require(uploads, "mission_upload")) return std::nullopt;
  auto state = svc.subscribe_polled<rejuv_msg_VehicleStateEstimate>("vehicle_state");
  if (!svc.require(state, "vehicle_state")) return std::nullopt;
  auto setpoint = svc.subscribe_polled<rejuv_msg_Setpoint>("setpoint");
  if (!svc.require(setpoint, "setpoint")) return std::nullopt;
  auto modes = svc.subscribe_polled<rejuv_msg_SrMode>("sr_mode");
  if (!svc.require(modes, "sr_mode")) return std::nullopt;
  auto events = svc.subscribe_polled<rejuv_msg_SecurityEvent>("security_event");
  if (!svc.require(events, "security_event")) return std::nullopt;
  std::optional<sdk::Subscription<rejuv_msg_SensorGps>> gps;
  if (svc.cap("sensor_gps")) {
    auto sub = svc.subscribe_polled<rejuv_msg_SensorGps>("sensor_gps");
    if (!svc.require(sub, "sensor_gps")) return std::nullopt;
    gps = *sub;
  }
  return Topics{.uploads = *uploads, .state = *state, .setpoint = *setpoint, .modes = *modes, .events = *events,
                .gps = gps};
}

// Home on Earth, for GLOBAL_POSITION_INT (optional: both coordinates or neither). False when the params
// are refused (logged).
bool set_home_from_params(sdk::Service& svc, services::ExtLink& link) {
  if (!svc.has_param("home_lat_deg") && !svc.has_param("home_lon_deg")) return true;
  const services::ExtLink::GeoHome home{.lat_deg = svc.param("home_lat_deg", 1000),
                                        .lon_deg = svc.param("home_lon_deg", 1000),
                                        .alt_m = svc.param("home_alt_m", 0)};
  if (!(std::abs(home.lat_deg) < 90 && std::abs(home.lon_deg) <= 180 && std::isfinite(home.alt_m))) {
    svc.logf(sdk::LogLevel::Error, "home_lat_deg, home_lon_deg, home_alt_m: expected both coordinates, latitude in "
             "(-90, 90) deg, longitude in [-180, 180] deg, a finite altitude; got %g, %g, %g",
             home.lat_deg, home.lon_deg, home.alt_m);
    return false;
  }
  link.set_home(home);
  return true;
}

// The glue between the ExtLink logic and the SDK: datagrams in, MAVLink messages and uploads out.
class GroundLink {
 public:
  GroundLink(sdk::Service& svc, services::ExtLink& link, const Topics& topics)
      : svc_(svc), link_(link), topics_(topics) {}

  void send(const mavlink::Message& m) {
    const mavlink::Frame f = link_.frame(m);
    auto ok = svc_.send_datagram(kNet, f.view());
    // Refused: no ground station has spoken yet (the kernel keeps its address, across rollbacks).
    const bool quiet = ok || ok.error().code == sdk::SdkError::NotHeldInMode ||
                       (ok.error().code == sdk::SdkError::OperationFailed &&
                        ok.error().wire_error == static_cast<std::int32_t>(wire::OpError::Refused));
    if (!quiet) {
      svc_.logf(sdk::LogLevel::Warn, "sending %s: %s", std::string(mavlink::name_of(m)).c_str(), ok.error().to_string().c_str());
    }
  }

  void on_datagram(std::span<const std::byte> datagram) {
    // What a request is answered from: the latest setpoint (where a clear holds) and the upload commander kept.
    // The kept upload is read here too, not only at the tick: a rollback restores ext_link to an image taken
    // outside MC, where the cell is not read, and a request can come before the window's first tick.
    if (topics_.setpoint.valid()) link_.observe_setpoint(topics_.setpoint.latest());
    if (svc_.may_send(kNet)) read_kept_upload();
    auto inbound = link_.on_datagram(datagram, svc_.now());
    // The verdict goes to the kernel: a valid message makes its sender the ground station telemetry goes
    // to; a refusal is counted there by reason (the run summary), where no rollback erases it.
    const std::uint32_t verdict = inbound ? 0U : 1U + static_cast<std::uint32_t>(inbound.error());
    if (auto judged = svc_.judge_datagram(kNet, verdict); !judged) {
      svc_.log(sdk::LogLevel::Warn, "judging a datagram: " + judged.error().to_string());
    }
    if (!inbound) {
      log_refusal(datagram.size(), inbound.error());
      return;
    }
    if (inbound->note) svc_.log(sdk::LogLevel::Warn, *inbound->note);
    for (const mavlink::Message& m : inbound->replies) send(m);
    if (inbound->forward) forward(*inbound->forward);
  }

  // Every tick, in every mode: what the SR cycle and the kernel show becomes STATUSTEXT (sent in MC). Then,
  // only in MC (the kernel refuses sends in the SEI, and an honest service asks only when it may), the
  // telemetry. Not gated on a ground station seen here: a rollback wipes what ext_link learned in MC, while
  // the kernel keeps the ground station's address (until one has spoken, a send is Refused and costs nothing).
  void on_tick() {
    // The SR cycle as the kernel published it on sr_mode (handed over in order before this timer's frame, so
    // a lockstep run sees the same modes whatever the scheduling), not the time page, which may be ahead.
    SrMode mode = svc_.mode();
    Epoch epoch = svc_.epoch();
    if (topics_.modes.valid()) {
      if (auto m = flight_io::mode_from_message(topics_.modes.latest())) {
        mode = *m;
        epoch = Epoch{topics_.modes.latest().epoch};
      }
    }
    const sdk::Subscription<rejuv_msg_SecurityEvent>& events = topics_.events;
    link_.observe(services::ExtLink::Observation{.mode = mode,
                                                 .epoch = epoch,
                                                 .security_events = events.received() + events.lost(),
                                                 .latest_event = events.valid() ? &events.latest() : nullptr});
    if (!svc_.may_send(kNet)) return;
    read_kept_upload();
    const services::ExtLink::TelemetryInputs in{
        .now = svc_.now(),
        .state = topics_.state.valid() ? &topics_.state.latest() : nullptr,
        .setpoint = topics_.setpoint.valid() ? &topics_.setpoint.latest() : nullptr,
        .gps = topics_.gps && topics_.gps->valid() ? &topics_.gps->latest() : nullptr,
        .mode = svc_.mode(),
        .epoch = svc_.epoch()};
    for (const mavlink::Message& m : link_.telemetry(in)) send(m);
  }

 private:
  // The upload commander kept (Persistent cell uploaded_mission; read only where the policy grants it, in MC):
  // the mission a download returns after a rollback has wiped what ext_link forwarded itself.
  void read_kept_upload() {
    auto kept = flight_io::read_mission_cell(svc_, "uploaded_mission");
    if (!kept) {
      svc_.log(sdk::LogLevel::Warn, "reading the kept upload: " + kept.error());
      return;
    }
    link_.set_kept_upload(*kept ? std::optional<flight_io::MissionSpec>((**kept).mission) : std::nullopt);
  }

  void log_refusal(std::size_t bytes, mavlink::DecodeError error) {
    std::uint64_t suppressed = 0;
    if (link_.should_log_refusal(svc_.now(), suppressed)) {
      svc_.logf(sdk::LogLevel::Warn, "refused a %zu-byte datagram: %s (%llu refused in all, %llu not logged)",
                bytes, std::string(mavlink::to_string(error)).c_str(),
                static_cast<unsigned long long>(link_.refused()), static_cast<unsigned long long>(suppressed));
    }
  }

  // Only in MC (the gate relays nothing else); a mode change in flight leaves the upload unanswered and the
  // ground station starts it again.
  void forward(const services::ExtLink::Forward& upload) {
    if (auto ok = topics_.uploads.publish(upload.upload); !ok) {
      svc_.log(sdk::LogLevel::Warn, "mission upload not forwarded: " + ok.error().to_string());
      link_.abandon();
      return;
    }
    switch (upload.request) {
      case services::ExtLink::Request::ReturnToLaunch:
        svc_.log(sdk::LogLevel::Info, "return to launch forwarded to commander");
        break;
      case services::ExtLink::Request::Clear:
        svc_.log(sdk::LogLevel::Info, "mission cleared: holding at the setpoint, forwarded to commander");
        break;
      case services::ExtLink::Request::Upload:
        svc_.logf(sdk::LogLevel::Info, "mission upload of %u waypoints forwarded to commander", upload.upload.count);
        break;
    }
    send(link_.forwarded(upload));
  }

  sdk::Service& svc_;
  services::ExtLink& link_;
  Topics topics_;
};

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  const double period_s = svc.param("telemetry_period_s", 0.1);
  if (!(std::isfinite(period_s) && period_s >= 0.01 && period_s <= 10)) {
    svc.logf(sdk::LogLevel::Error, "telemetry_period_s: expected 0.01 to 10 s, got %g", period_s);
    return 1;
  }
  // Uploads are judged by commander's check, with the same params (the mission's home, geofence.*).
  auto made = services::ExtLink::from_params(flight_io::params_of(svc));
  if (!svc.require(made, "refusing the mission")) return 1;
  services::ExtLink& link = *made;
  link.set_telemetry_period(period_s);
  if (!set_home_from_params(svc, link)) return 1;
  const std::optional<Topics> topics = open_topics(svc);
  if (!topics) return 1;
  GroundLink ground(svc, link, *topics);
  auto gate = svc.on_datagram(kNet, [&](std::span<const std::byte> datagram) { ground.on_datagram(datagram); });
  if (!svc.require(gate, "ext_net")) return 1;
  auto telemetry = svc.every(to_nanos(Seconds{period_s}), [&] { ground.on_tick(); });
  if (!svc.require(telemetry, "timer")) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve, services::AttackHooks::Install); }
