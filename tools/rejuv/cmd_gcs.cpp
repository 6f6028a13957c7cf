// `rejuv gcs`: a minimal MAVLink 2 ground control station on the other side of the kernel's network gate
// (docs/design.md §2, §10; docs/mavlink.md). It asks for the vehicle's home (MAV_CMD_REQUEST_MESSAGE
// HOME_POSITION), uploads a mission with the MAVLink mission protocol (MISSION_COUNT → MISSION_REQUEST_INT →
// MISSION_ITEM_INT … → MISSION_ACK) planned in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT against it (LOCAL_NED when
// the vehicle has no home), downloads it back and says whether it is the mission uploaded, retransmitting its last message
// every 200 ms until the vehicle answers — so an upload made during the secure execution interval, where the
// gate drops everything, simply waits for MC — and prints the telemetry and STATUSTEXT the vehicle sends (MC
// only). With --key (or --key-file) every frame it sends is signed (MAVLink 2 message signing), as the
// kernel's gate requires when the launch file's network block has a signing key. Exit 0 when the upload was
// acknowledged MAV_MISSION_ACCEPTED (or, watching only, when telemetry arrived), 1 when it was refused (the
// error code and the vehicle's STATUSTEXT are printed), not acknowledged within --timeout (or no telemetry
// came), 2 on bad flags or a bad launch file.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/mavlink/mission.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv::cli {
namespace {

constexpr std::chrono::milliseconds kHeartbeatPeriod{1000};
constexpr std::size_t kMaxUploadWaypoints = 16;  // what ext_link takes (idl/control.idl MissionWaypoints)
constexpr std::uint8_t kGcsSystem = 255;         // MAVLink's customary ground station ids
constexpr std::uint8_t kGcsComponent = 190;      // MAV_COMP_ID_MISSIONPLANNER

struct Upload {
  std::vector<mavlink::LocalWaypoint> waypoints{};
  double acceptance_radius_m = 0.05;
};

// "N,E,D[,YAW];N,E,D[,YAW];…" (local NED [m], yaw [rad]).
Result<Upload, std::string> parse_waypoints(std::string_view text) {
  Upload up;
  std::size_t index = 0;
  while (!text.empty()) {
    const auto semi = text.find(';');
    const std::string_view item = text.substr(0, semi);
    text = semi == std::string_view::npos ? std::string_view{} : text.substr(semi + 1);
    if (item.empty()) continue;
    std::vector<double> numbers;
    std::string_view rest = item;
    while (true) {
      const auto comma = rest.find(',');
      auto v = to_double(rest.substr(0, comma), "--waypoints");
      if (!v) {
        return fail("--waypoints: waypoint " + std::to_string(index + 1) + ": expected N,E,D[,YAW] as finite numbers, got '" +
                    std::string(item) + "'");
      }
      numbers.push_back(*v);
      if (comma == std::string_view::npos) break;
      rest = rest.substr(comma + 1);
    }
    if (numbers.size() < 3 || numbers.size() > 4) {
      return fail("--waypoints: waypoint " + std::to_string(index + 1) + ": expected 3 or 4 numbers (N,E,D[,YAW]), got '" +
                  std::string(item) + "'");
    }
    if (index >= kMaxUploadWaypoints) {
      return fail("--waypoints: at most " + std::to_string(kMaxUploadWaypoints) + " waypoints");
    }
    ++index;
    up.waypoints.push_back(mavlink::LocalWaypoint{
        .north_m = numbers[0], .east_m = numbers[1], .down_m = numbers[2], .yaw_rad = numbers.size() == 4 ? numbers[3] : 0.0});
  }
  if (index == 0) return fail("--waypoints: no waypoint given (expected N,E,D[,YAW];…)");
  return up;
}

Result<Upload, std::string> mission_of_launch(const std::filesystem::path& path) {
  auto loaded = launch::load_launch(path);
  if (!loaded) return fail(loaded.error().to_string());
  const proto::Mission& m = loaded->graph.mission();
  if (m.waypoints_size() == 0) return fail("--upload: " + path.string() + " has no mission waypoints");
  if (static_cast<std::size_t>(m.waypoints_size()) > kMaxUploadWaypoints) {
    return fail("--upload: " + path.string() + " has " + std::to_string(m.waypoints_size()) + " waypoints; an upload holds at most " +
                std::to_string(kMaxUploadWaypoints));
  }
  Upload up;
  if (m.acceptance_radius_m() > 0) up.acceptance_radius_m = m.acceptance_radius_m();
  for (int i = 0; i < m.waypoints_size(); ++i) {
    const proto::Waypoint& w = m.waypoints(i);
    up.waypoints.push_back(
        mavlink::LocalWaypoint{.north_m = w.north_m(), .east_m = w.east_m(), .down_m = w.down_m(), .yaw_rad = w.yaw_rad()});
  }
  return up;
}

const char* mode_text(std::uint32_t custom_mode) {
  const std::uint32_t mode = custom_mode & 0xFFU;  // docs/mavlink.md "HEARTBEAT"
  return mode < kModeCount ? mode_name(kAllModes[mode]) : "?";
}

// The signing key of --key-file: 64 hex digits, surrounding white space ignored.
Result<mavlink::SigningKey, std::string> key_of_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return fail("--key-file: cannot read " + path.string());
  std::ostringstream text;
  text << in.rdbuf();
  std::string hex = text.str();
  while (!hex.empty() && std::isspace(static_cast<unsigned char>(hex.back())) != 0) hex.pop_back();
  while (!hex.empty() && std::isspace(static_cast<unsigned char>(hex.front())) != 0) hex.erase(hex.begin());
  auto key = mavlink::SigningKey::from_hex(hex);
  if (!key) return fail("--key-file: " + path.string() + ": " + key.error());
  return *key;
}

// What `rejuv gcs` was asked for.
struct GcsRequest {
  std::optional<std::uint64_t> port;
  std::string host = "127.0.0.1";
  std::optional<std::filesystem::path> upload_path, key_path;
  std::optional<Upload> waypoints;
  std::optional<mavlink::SigningKey> key;
  std::optional<double> radius, watch_s;
  std::optional<std::uint64_t> link_id;
  double timeout_s = 60;
  bool all = false;
};

Result<mavlink::SigningKey, std::string> parse_key(std::string_view hex) {
  auto k = mavlink::SigningKey::from_hex(hex);
  if (!k) return fail("--key: " + k.error());
  return *k;
}

void declare_gcs_options(Options& opts, GcsRequest& r) {
  opts.integer("--port", "P", r.port, {1, 0xFFFF}, "the kernel's network gate port; required")
      .text("--host", "IP", r.host, "the kernel's address")
      .path("--upload", "LAUNCH_FILE", r.upload_path, "upload the mission of this launch graph")
      .custom<Upload>("--waypoints", "N,E,D[,YAW];...", r.waypoints, parse_waypoints,
                      "upload these waypoints (local NED [m], yaw [rad])")
      .real("--acceptance-radius", "M", r.radius, {.min = 0, .open_min = true},
            "acceptance radius of the uploaded mission [m]")
      .real("--watch", "SECONDS", r.watch_s, {.min = 0, .max = 1e6},
            "print telemetry for this long (after the upload is acknowledged)", "0 with an upload, 10 without")
      .real("--timeout", "SECONDS", r.timeout_s, {.min = 0.1, .max = 1e6}, "give up on the acknowledgement after this long")
      .custom<mavlink::SigningKey>("--key", "HEX", r.key, parse_key, "sign every frame with this 32-byte key (64 hex digits)")
      .path("--key-file", "PATH", r.key_path, "sign with the key in this file (64 hex digits)")
      .integer("--link-id", "N", r.link_id, {0, 255}, "the signing link id", "1")
      .flag("--all", r.all, "print every telemetry message (default: at most two lines a second)");
}

// The session the request asks for, every flag checked against the others.
struct GcsPlan {
  sys::UdpAddress kernel;
  std::optional<Upload> upload;
  std::optional<mavlink::SigningKey> key;
  std::uint8_t link_id = 1;
  Nanos watch{0}, timeout{0};
  bool all = false;
};

// The mission to upload: --upload's launch file, --waypoints, or none; --acceptance-radius applied.
Result<std::optional<Upload>, std::string> upload_of(const GcsRequest& r) {
  Upload up;
  if (r.upload_path) {
    auto m = mission_of_launch(*r.upload_path);
    if (!m) return fail(m.error());
    up = std::move(*m);
  } else if (r.waypoints) {
    up = *r.waypoints;
  } else {
    return std::optional<Upload>{};
  }
  if (r.radius) up.acceptance_radius_m = *r.radius;
  return std::optional<Upload>(std::move(up));
}

Result<GcsPlan, std::string> plan_gcs(const GcsRequest& r) {
  if (!r.port) return fail(std::string("--port is required (the kernel's network gate port)"));
  auto kernel = sys::UdpAddress::parse(r.host, static_cast<std::uint16_t>(*r.port));
  if (!kernel) return fail("--host: " + kernel.error());
  if (r.upload_path && r.waypoints) return fail(std::string("give --upload or --waypoints, not both"));
  if (r.key && r.key_path) return fail(std::string("give --key or --key-file, not both"));
  if (r.radius && !r.upload_path && !r.waypoints) return fail(std::string("--acceptance-radius needs --upload or --waypoints"));
  std::optional<mavlink::SigningKey> key = r.key;
  if (r.key_path) {
    auto k = key_of_file(*r.key_path);
    if (!k) return fail(k.error());
    key = *k;
  }
  auto upload = upload_of(r);
  if (!upload) return fail(upload.error());
  const Nanos watch = to_nanos(Seconds{r.watch_s.value_or(*upload ? 0.0 : 10.0)});
  return GcsPlan{.kernel = *kernel,
                 .upload = std::move(*upload),
                 .key = key,
                 .link_id = static_cast<std::uint8_t>(r.link_id.value_or(1)),
                 .watch = watch,
                 .timeout = to_nanos(Seconds{r.timeout_s}),
                 .all = r.all};
}

// One ground-station session over UDP: the upload (retransmitted until answered), the heartbeat, and the
// vehicle's telemetry and STATUSTEXT printed. run() returns the exit code.
class GroundStation {
 public:
  GroundStation(const GcsPlan& plan, sys::UdpSocket socket)
      : plan_(plan), socket_(std::move(socket)), start_(sys::monotonic_now()), next_upload_(start_),
        next_heartbeat_(start_) {
    if (plan_.upload) {
      uploader_.emplace(plan_.upload->waypoints, plan_.upload->acceptance_radius_m);
      // First home on Earth (HOME_POSITION), to plan in global coordinates as QGroundControl does.
      phase_ = Phase::Home;
      pending_ = request_home();
    } else {
      acked_at_ = start_;
    }
  }

  int run() {
    announce();
    for (;;) {
      const Nanos now = sys::monotonic_now();
      if (!acked_at_) {
        if (now - start_ >= plan_.timeout) {
          std::printf("rejuv gcs: no acknowledgement after %.1f s and %llu transmissions; giving up\n", elapsed(),
                      static_cast<unsigned long long>(transmissions_));
          return static_cast<int>(Exit::Findings);
        }
        if (now >= next_upload_ && pending_) transmit(*pending_);
      } else if (now - *acked_at_ >= plan_.watch) {
        break;
      }
      if (now >= next_heartbeat_) heartbeat(now);
      const Nanos wake = acked_at_ ? std::min(next_heartbeat_, *acked_at_ + plan_.watch) : std::min(next_heartbeat_, next_upload_);
      if (auto ready = sys::wait_fd(socket_.fd(), sys::WaitFor::Readable, std::max(Nanos{0}, wake - now)); !ready) {
        return refuse("rejuv gcs: " + ready.error().to_string());
      }
      if (auto exit = drain()) return *exit;
    }
    std::printf("rejuv gcs: %llu telemetry message(s)%s\n", static_cast<unsigned long long>(telemetry_),
                malformed_ > 0 ? (", " + std::to_string(malformed_) + " malformed datagram(s) ignored").c_str() : "");
    const bool good = plan_.upload ? acked_at_.has_value() : telemetry_ > 0;
    return static_cast<int>(good ? Exit::Ok : Exit::Findings);
  }

 private:
  double elapsed() const { return to_seconds(sys::monotonic_now() - start_).count(); }

  void announce() const {
    if (plan_.upload) {
      std::printf("rejuv gcs: uploading %zu waypoints to %s%s (MAVLink mission protocol; retransmitted every 200 ms until "
                  "answered)\n",
                  plan_.upload->waypoints.size(), plan_.kernel.to_string().c_str(), plan_.key ? ", signed" : "");
    } else {
      std::printf("rejuv gcs: watching telemetry from %s\n", plan_.kernel.to_string().c_str());
    }
    std::fflush(stdout);
  }

  void send(const mavlink::Message& m) {
    std::optional<mavlink::Signer> signer;
    if (plan_.key) {
      // From the wall clock (the receiver refuses a timestamp more than a minute behind its own), strictly
      // increasing per stream (it refuses a repeated one as a replay).
      last_timestamp_ = std::max(mavlink::SigningClock::now(), last_timestamp_ + mavlink::SigningClock::duration{1});
      signer = mavlink::Signer{.key = *plan_.key, .link_id = plan_.link_id, .timestamp = last_timestamp_};
    }
    const mavlink::Frame f =
        mavlink::encode(m, mavlink::Envelope{.seq = seq_++, .sysid = kGcsSystem, .compid = kGcsComponent}, signer);
    if (auto ok = socket_.send_to(f.view(), plan_.kernel); !ok) {
      std::fprintf(stderr, "rejuv gcs: %s\n", ok.error().to_string().c_str());
    }
  }

  void transmit(const mavlink::Message& m) {
    send(m);
    ++transmissions_;
    next_upload_ = sys::monotonic_now() + std::chrono::milliseconds{200};
  }

  // A ground station's HEARTBEAT: keeps telemetry coming (says where to send it).
  void heartbeat(Nanos now) {
    send(mavlink::Heartbeat{.custom_mode = 0, .type = mavlink::kMavTypeGcs, .autopilot = mavlink::kMavAutopilotInvalid,
                            .base_mode = 0, .system_status = mavlink::kMavStateActive, .mavlink_version = 3});
    next_heartbeat_ = now + kHeartbeatPeriod;
  }

  // Everything the socket holds; an exit code when the upload was refused.
  std::optional<int> drain() {
    for (;;) {
      auto r = socket_.receive(buf_);
      if (!r) return std::nullopt;  // EAGAIN: drained
      if (!(r->from == plan_.kernel)) continue;  // not from the vehicle
      auto p = mavlink::decode(std::span<const std::byte>(buf_.data(), r->size));
      if (!p || r->truncated) {
        ++malformed_;
        continue;
      }
      if (const auto* text = std::get_if<mavlink::StatusText>(&p->message)) {
        on_status_text(*text);
        continue;
      }
      if (uploader_ && !acked_at_) {
        if (auto exit = on_session_reply(p->message)) return exit;
      }
      on_telemetry(p->message);
    }
  }

  void on_status_text(const mavlink::StatusText& text) {
    const std::string t = mavlink::text_of(text);
    if (t.starts_with("mission refused: ")) refusal_text_ = t.substr(17);
    std::printf("STATUSTEXT [%u] %s\n", text.severity, t.c_str());
    std::fflush(stdout);
  }

  static mavlink::Message request_home() {
    return mavlink::CommandLong{.param1 = static_cast<float>(mavlink::HomePosition::kId), .param2 = 0, .param3 = 0,
                                .param4 = 0, .param5 = 0, .param6 = 0, .param7 = 0, .command = kRequestMessage,
                                .target_system = 1, .target_component = 1, .confirmation = 0};
  }

  void start_upload() {
    phase_ = Phase::Upload;
    if (home_) {
      uploader_->plan_in_global(*home_);
      std::printf("rejuv gcs: home %.7f, %.7f, %.1f m AMSL: planning in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT\n",
                  home_->lat_deg, home_->lon_deg, home_->alt_m);
    } else {
      std::printf("rejuv gcs: the vehicle has no home on Earth: planning in MAV_FRAME_LOCAL_NED\n");
    }
    std::fflush(stdout);
    pending_ = uploader_->start();
    transmit(*pending_);
  }

  // The session's next step (home, upload, download); an exit code when the vehicle refused the upload or the
  // download differs from it.
  std::optional<int> on_session_reply(const mavlink::Message& m) {
    switch (phase_) {
      case Phase::Home:
        if (const auto* h = std::get_if<mavlink::HomePosition>(&m)) {
          home_ = mavlink::GeoHome{.lat_deg = h->latitude / mavlink::kGlobalIntScale,
                                   .lon_deg = h->longitude / mavlink::kGlobalIntScale, .alt_m = h->altitude * 1e-3};
          start_upload();
        } else if (const auto* a = std::get_if<mavlink::CommandAck>(&m); a != nullptr && a->command == kRequestMessage &&
                                                                          a->result != 0) {
          start_upload();
        }
        return std::nullopt;
      case Phase::Upload: return on_upload_reply(m);
      case Phase::Download: return on_download_reply(m);
    }
    return std::nullopt;
  }

  // The mission protocol's next step; an exit code when the vehicle refused the upload.
  std::optional<int> on_upload_reply(const mavlink::Message& m) {
    if (auto reply = uploader_->on_message(m)) {
      pending_ = *reply;
      transmit(*reply);
    }
    if (uploader_->status() == mavlink::MissionUploader::Status::Refused) {
      print_refusal();
      return static_cast<int>(Exit::Findings);
    }
    if (uploader_->status() == mavlink::MissionUploader::Status::Accepted) {
      std::printf("rejuv gcs: upload acknowledged by ext_link after %.1f s and %llu transmission(s)%s\n", elapsed(),
                  static_cast<unsigned long long>(transmissions_),
                  uploader_->restarts() > 0 ? (", " + std::to_string(uploader_->restarts()) + " restart(s)").c_str() : "");
      std::fflush(stdout);
      // Then downloaded back (MISSION_REQUEST_LIST → MISSION_COUNT → MISSION_REQUEST_INT each).
      phase_ = Phase::Download;
      pending_ = mavlink::MissionRequestList{.target_system = 1, .target_component = 1, .mission_type = 0};
      transmit(*pending_);
    }
    return std::nullopt;
  }

  // The download after the upload: printed with whether it is the mission uploaded (it is not when a rollback
  // wiped ext_link's memory of the upload and the graph grants it no read of commander's kept one).
  std::optional<int> on_download_reply(const mavlink::Message& m) {
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    if (const auto* c = std::get_if<mavlink::MissionCount>(&m); c != nullptr && c->mission_type == 0 && !download_count_) {
      download_count_ = c->count;
    } else if (const auto* item = std::get_if<mavlink::MissionItemInt>(&m);
               item != nullptr && download_count_ && item->seq == downloaded_.size()) {
      const auto w = mavlink::waypoint_in_frame(*item, home_);
      downloaded_.push_back(w.value_or(mavlink::LocalWaypoint{.north_m = kNaN, .east_m = kNaN, .down_m = kNaN, .yaw_rad = 0}));
    } else {
      return std::nullopt;
    }
    if (downloaded_.size() < *download_count_) {
      pending_ = mavlink::MissionRequestInt{.seq = static_cast<std::uint16_t>(downloaded_.size()), .target_system = 1,
                                            .target_component = 1, .mission_type = 0};
      transmit(*pending_);
      return std::nullopt;
    }
    send(mavlink::MissionAck{.target_system = 1, .target_component = 1, .type = 0, .mission_type = 0, .opaque_id = 0});
    pending_.reset();
    acked_at_ = sys::monotonic_now();
    // What was uploaded, within the 10⁻⁷° (1.1 cm) of the global frames.
    const auto& up = plan_.upload->waypoints;
    bool same = downloaded_.size() == up.size();
    for (std::size_t i = 0; same && i < up.size(); ++i) {
      same = std::hypot(downloaded_[i].north_m - up[i].north_m, downloaded_[i].east_m - up[i].east_m,
                        downloaded_[i].down_m - up[i].down_m) < 0.05;
    }
    std::printf("rejuv gcs: downloaded %zu waypoint(s): %s\n", downloaded_.size(),
                same ? "the mission uploaded" : "NOT the mission uploaded");
    std::fflush(stdout);
    return std::nullopt;
  }

  // A negative acknowledgement: the upload is not a mission commander would keep; nothing changed.
  void print_refusal() const {
    std::printf("rejuv gcs: upload refused by ext_link after %.1f s and %llu transmission(s): %s", elapsed(),
                static_cast<unsigned long long>(transmissions_), std::string(mavlink::to_string(uploader_->result())).c_str());
    if (!refusal_text_.empty()) {
      // "outside the geofence (item I)": name the waypoint counting from 1, as the launch file does.
      const auto item = refusal_text_.rfind("(item ");
      const std::string reason = refusal_text_.substr(0, item == std::string::npos ? refusal_text_.size() : item);
      std::printf(": %s", reason.c_str());
      if (item != std::string::npos) {
        const std::size_t i = std::strtoul(refusal_text_.c_str() + item + 6, nullptr, 10);
        if (i < plan_.upload->waypoints.size()) {
          const mavlink::LocalWaypoint& w = plan_.upload->waypoints[i];
          std::printf("(waypoint %zu: N %.2f E %.2f D %.2f m)", i + 1, w.north_m, w.east_m, w.down_m);
        }
      }
    }
    std::printf("; the vehicle flies on unchanged\n");
    std::fflush(stdout);
  }

  // HEARTBEATs each, LOCAL_POSITION_NED at most two lines a second (every one with --all).
  void on_telemetry(const mavlink::Message& m) {
    const bool is_telemetry =
        std::holds_alternative<mavlink::LocalPositionNed>(m) || std::holds_alternative<mavlink::Heartbeat>(m);
    if (!is_telemetry) return;
    ++telemetry_;
    const Nanos at = sys::monotonic_now();
    if (const auto* hb = std::get_if<mavlink::Heartbeat>(&m)) {
      std::printf("HEARTBEAT  mode %s  epoch %u\n", mode_text(hb->custom_mode), hb->custom_mode >> 8U);
      std::fflush(stdout);
      return;
    }
    if (!plan_.all && at - last_print_ < std::chrono::milliseconds{500}) return;
    last_print_ = at;
    const auto& lp = std::get<mavlink::LocalPositionNed>(m);
    std::printf("t=%8.3f s  p=(%6.2f, %6.2f, %6.2f) m  v=(%5.2f, %5.2f, %5.2f) m/s\n", lp.time_boot_ms * 1e-3,
                static_cast<double>(lp.x), static_cast<double>(lp.y), static_cast<double>(lp.z),
                static_cast<double>(lp.vx), static_cast<double>(lp.vy), static_cast<double>(lp.vz));
    std::fflush(stdout);
  }

  const GcsPlan& plan_;
  sys::UdpSocket socket_;
  static constexpr std::uint16_t kRequestMessage = 512;  // MAV_CMD_REQUEST_MESSAGE
  enum class Phase : std::uint8_t { Home, Upload, Download };
  std::optional<mavlink::MissionUploader> uploader_;
  Phase phase_ = Phase::Home;
  std::optional<mavlink::Message> pending_;  // retransmitted every 200 ms until answered
  std::optional<mavlink::GeoHome> home_;
  std::optional<std::size_t> download_count_;
  std::vector<mavlink::LocalWaypoint> downloaded_;
  Nanos start_, next_upload_, next_heartbeat_, last_print_{0};
  std::optional<Nanos> acked_at_;  // set once the upload was acknowledged (at once when there is none)
  std::uint8_t seq_ = 0;
  mavlink::SigningTime last_timestamp_{};
  std::uint64_t transmissions_ = 0, telemetry_ = 0, malformed_ = 0;
  std::string refusal_text_;  // the vehicle's STATUSTEXT about a refused mission
  std::array<std::byte, mavlink::kMaxFrameBytes + 1> buf_{};
};

}  // namespace

int run_gcs(std::span<const std::string_view> args) {
  GcsRequest r;
  Options opts("gcs",
               "A minimal MAVLink 2 ground control station for the kernel's network gate (UDP, docs/mavlink.md).\n"
               "Uploads a mission with the MAVLink mission protocol, retransmitting its last message every 200 ms\n"
               "until the vehicle answers (during the secure execution interval the gate drops everything, so the\n"
               "upload waits for MC), then prints the telemetry and STATUSTEXT the vehicle sends in MC. The\n"
               "kernel's port is in `rejuv run`'s log (\"network gate: udp 127.0.0.1:P\"; launch\n"
               "`network.bind_port`, default 14555). Signs what it sends with --key/--key-file (MAVLink 2 signing).\n"
               "Exit 0 when the upload was acknowledged (watching only: when telemetry arrived), 1 when it\n"
               "was refused (the MAV_MISSION_RESULT and the vehicle's reason are printed: outside the geofence,\n"
               "below the altitude floor, too many waypoints) or not acknowledged in time, 2 on bad flags.");
  declare_gcs_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  const auto plan = plan_gcs(r);
  if (!plan) return refuse("rejuv gcs: " + plan.error());
  auto socket = sys::UdpSocket::bind(sys::UdpAddress::loopback(0), sys::Blocking::No);
  if (!socket) return refuse("rejuv gcs: " + socket.error().to_string());
  GroundStation station(*plan, std::move(*socket));
  return station.run();
}

}  // namespace rejuv::cli
