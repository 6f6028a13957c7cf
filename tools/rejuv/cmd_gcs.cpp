// `rejuv gcs`: a minimal MAVLink 2 ground control station on the other side of the kernel's network gate
// (DESIGN §2, §10; docs/mavlink.md). It uploads a mission with the MAVLink mission protocol
// (MISSION_COUNT → MISSION_REQUEST_INT → MISSION_ITEM_INT … → MISSION_ACK), retransmitting its last message
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

}  // namespace

int run_gcs(std::span<const std::string_view> args) {
  std::optional<std::uint64_t> port;
  std::string host = "127.0.0.1";
  std::optional<std::filesystem::path> upload_path, key_path;
  std::optional<Upload> waypoints;
  std::optional<mavlink::SigningKey> key;
  std::optional<double> radius, watch_s;
  std::optional<std::uint64_t> link_id;
  double timeout_s = 60;
  bool all = false;
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
  opts.integer("--port", "P", port, {1, 0xFFFF}, "the kernel's network gate port; required")
      .text("--host", "IP", host, "the kernel's address")
      .path("--upload", "LAUNCH_FILE", upload_path, "upload the mission of this launch graph")
      .custom<Upload>("--waypoints", "N,E,D[,YAW];...", waypoints, parse_waypoints,
                      "upload these waypoints (local NED [m], yaw [rad])")
      .real("--acceptance-radius", "M", radius, {.min = 0, .open_min = true},
            "acceptance radius of the uploaded mission [m]")
      .real("--watch", "SECONDS", watch_s, {.min = 0, .max = 1e6},
            "print telemetry for this long (after the upload is acknowledged)", "0 with an upload, 10 without")
      .real("--timeout", "SECONDS", timeout_s, {.min = 0.1, .max = 1e6}, "give up on the acknowledgement after this long")
      .custom<mavlink::SigningKey>("--key", "HEX", key,
                                   [](std::string_view hex) -> Result<mavlink::SigningKey, std::string> {
                                     auto k = mavlink::SigningKey::from_hex(hex);
                                     if (!k) return fail("--key: " + k.error());
                                     return *k;
                                   },
                                   "sign every frame with this 32-byte key (64 hex digits)")
      .path("--key-file", "PATH", key_path, "sign with the key in this file (64 hex digits)")
      .integer("--link-id", "N", link_id, {0, 255}, "the signing link id", "1")
      .flag("--all", all, "print every telemetry message (default: at most two lines a second)");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (!port) return bad_input("rejuv gcs: --port is required (the kernel's network gate port)");
  auto kernel = sys::UdpAddress::parse(host, static_cast<std::uint16_t>(*port));
  if (!kernel) return bad_input("rejuv gcs: --host: " + kernel.error());
  if (upload_path && waypoints) return bad_input("rejuv gcs: give --upload or --waypoints, not both");
  if (key && key_path) return bad_input("rejuv gcs: give --key or --key-file, not both");
  if (radius && !upload_path && !waypoints) {
    return bad_input("rejuv gcs: --acceptance-radius needs --upload or --waypoints");
  }
  if (key_path) {
    auto k = key_of_file(*key_path);
    if (!k) return bad_input("rejuv gcs: " + k.error());
    key = *k;
  }

  std::optional<Upload> upload = waypoints;
  if (upload_path) {
    auto m = mission_of_launch(*upload_path);
    if (!m) return bad_input("rejuv gcs: " + m.error());
    upload = *m;
  }
  if (upload && radius) upload->acceptance_radius_m = *radius;
  const Nanos watch = to_nanos(Seconds{watch_s.value_or(upload ? 0.0 : 10.0)});
  const Nanos timeout = to_nanos(Seconds{timeout_s});

  auto socket = sys::UdpSocket::bind(sys::UdpAddress::loopback(0), sys::Blocking::No);
  if (!socket) return bad_input("rejuv gcs: " + socket.error().to_string());
  const Nanos start = sys::monotonic_now();
  const auto elapsed = [&] { return to_seconds(sys::monotonic_now() - start).count(); };
  std::uint8_t seq = 0;
  std::uint64_t last_timestamp = 0;
  const auto send = [&](const mavlink::Message& m) {
    std::optional<mavlink::Signer> signer;
    if (key) {
      // Strictly increasing per stream (the receiver refuses a repeated timestamp as a replay).
      last_timestamp = std::max(mavlink::signing_timestamp_now(), last_timestamp + 1);
      signer = mavlink::Signer{.key = *key, .link_id = static_cast<std::uint8_t>(link_id.value_or(1)), .timestamp = last_timestamp};
    }
    const mavlink::Frame f =
        mavlink::encode(m, mavlink::Envelope{.seq = seq++, .sysid = kGcsSystem, .compid = kGcsComponent}, signer);
    if (auto ok = socket->send_to(f.view(), *kernel); !ok) {
      std::fprintf(stderr, "rejuv gcs: %s\n", ok.error().to_string().c_str());
    }
  };

  std::optional<mavlink::MissionUploader> uploader;
  if (upload) {
    uploader.emplace(upload->waypoints, upload->acceptance_radius_m);
    std::printf("rejuv gcs: uploading %zu waypoints to %s%s (MAVLink mission protocol; retransmitted every 200 ms until "
                "answered)\n",
                upload->waypoints.size(), kernel->to_string().c_str(), key ? ", signed" : "");
  } else {
    std::printf("rejuv gcs: watching telemetry from %s\n", kernel->to_string().c_str());
  }
  std::fflush(stdout);
  bool acked = !upload.has_value();
  std::optional<Nanos> acked_at = acked ? std::optional<Nanos>(start) : std::nullopt;
  std::uint64_t transmissions = 0, telemetry = 0, malformed = 0;
  Nanos next_upload = start, next_heartbeat = start, last_print{0};
  std::string refusal_text;  // the vehicle's STATUSTEXT about a refused mission
  std::array<std::byte, mavlink::kMaxFrameBytes + 1> buf{};
  const auto transmit = [&](const mavlink::Message& m) {
    send(m);
    ++transmissions;
    next_upload = sys::monotonic_now() + std::chrono::milliseconds{200};
  };
  for (;;) {
    const Nanos now = sys::monotonic_now();
    if (!acked) {
      if (now - start >= timeout) {
        std::printf("rejuv gcs: no acknowledgement after %.1f s and %llu transmissions; giving up\n", elapsed(),
                    static_cast<unsigned long long>(transmissions));
        return static_cast<int>(Exit::Findings);
      }
      if (now >= next_upload) transmit(transmissions == 0 ? uploader->start() : uploader->last_sent());
    } else if (now - *acked_at >= watch) {
      break;
    }
    if (now >= next_heartbeat) {  // a ground station's HEARTBEAT: keeps telemetry coming (says where to send it)
      send(mavlink::Heartbeat{.custom_mode = 0, .type = mavlink::kMavTypeGcs, .autopilot = mavlink::kMavAutopilotInvalid,
                              .base_mode = 0, .system_status = mavlink::kMavStateActive, .mavlink_version = 3});
      next_heartbeat = now + kHeartbeatPeriod;
    }
    const Nanos wake = acked ? std::min(next_heartbeat, *acked_at + watch) : std::min(next_heartbeat, next_upload);
    if (auto ready = sys::wait_fd(socket->fd(), sys::WaitFor::Readable, std::max(Nanos{0}, wake - now)); !ready) {
      return bad_input("rejuv gcs: " + ready.error().to_string());
    }
    for (;;) {
      auto r = socket->receive(buf);
      if (!r) break;  // EAGAIN: drained
      if (!(r->from == *kernel)) continue;  // not from the vehicle
      auto p = mavlink::decode(std::span<const std::byte>(buf.data(), r->size));
      if (!p || r->truncated) {
        ++malformed;
        continue;
      }
      if (const auto* text = std::get_if<mavlink::StatusText>(&p->message)) {
        const std::string t = mavlink::text_of(*text);
        if (t.starts_with("mission refused: ")) refusal_text = t.substr(17);
        std::printf("STATUSTEXT [%u] %s\n", text->severity, t.c_str());
        std::fflush(stdout);
        continue;
      }
      if (uploader && !acked) {
        if (auto reply = uploader->on_message(p->message)) transmit(*reply);
        if (uploader->status() == mavlink::MissionUploader::Status::Refused) {
          // A negative acknowledgement: the upload is not a mission commander would keep; nothing changed.
          std::printf("rejuv gcs: upload refused by ext_link after %.1f s and %llu transmission(s): %s",
                      elapsed(), static_cast<unsigned long long>(transmissions),
                      std::string(mavlink::to_string(uploader->result())).c_str());
          if (!refusal_text.empty()) {
            // "outside the geofence (item I)": name the waypoint counting from 1, as the launch file does.
            const auto item = refusal_text.rfind("(item ");
            const std::string reason = refusal_text.substr(0, item == std::string::npos ? refusal_text.size() : item);
            std::printf(": %s", reason.c_str());
            if (item != std::string::npos) {
              const std::size_t i = std::strtoul(refusal_text.c_str() + item + 6, nullptr, 10);
              if (i < upload->waypoints.size()) {
                const mavlink::LocalWaypoint& w = upload->waypoints[i];
                std::printf("(waypoint %zu: N %.2f E %.2f D %.2f m)", i + 1, w.north_m, w.east_m, w.down_m);
              }
            }
          }
          std::printf("; the vehicle flies on unchanged\n");
          std::fflush(stdout);
          return static_cast<int>(Exit::Findings);
        }
        if (uploader->status() == mavlink::MissionUploader::Status::Accepted) {
          acked = true;
          acked_at = sys::monotonic_now();
          std::printf("rejuv gcs: upload acknowledged by ext_link after %.1f s and %llu transmission(s)%s\n", elapsed(),
                      static_cast<unsigned long long>(transmissions),
                      uploader->restarts() > 0 ? (", " + std::to_string(uploader->restarts()) + " restart(s)").c_str() : "");
          std::fflush(stdout);
        }
      }
      const bool is_telemetry = std::holds_alternative<mavlink::LocalPositionNed>(p->message) ||
                                std::holds_alternative<mavlink::Heartbeat>(p->message);
      if (!is_telemetry) continue;
      ++telemetry;
      const Nanos at = sys::monotonic_now();
      if (const auto* hb = std::get_if<mavlink::Heartbeat>(&p->message)) {
        std::printf("HEARTBEAT  mode %s  epoch %u\n", mode_text(hb->custom_mode), hb->custom_mode >> 8U);
        std::fflush(stdout);
        continue;
      }
      if (!all && at - last_print < std::chrono::milliseconds{500}) continue;
      last_print = at;
      const auto& lp = std::get<mavlink::LocalPositionNed>(p->message);
      std::printf("t=%8.3f s  p=(%6.2f, %6.2f, %6.2f) m  v=(%5.2f, %5.2f, %5.2f) m/s\n", lp.time_boot_ms * 1e-3,
                  static_cast<double>(lp.x), static_cast<double>(lp.y), static_cast<double>(lp.z),
                  static_cast<double>(lp.vx), static_cast<double>(lp.vy), static_cast<double>(lp.vz));
      std::fflush(stdout);
    }
  }
  std::printf("rejuv gcs: %llu telemetry message(s)%s\n", static_cast<unsigned long long>(telemetry),
              malformed > 0 ? (", " + std::to_string(malformed) + " malformed datagram(s) ignored").c_str() : "");
  const bool good = upload ? acked : telemetry > 0;
  return static_cast<int>(good ? Exit::Ok : Exit::Findings);
}

}  // namespace rejuv::cli
