// `rejuv gcs`: a minimal ground control station on the other side of the kernel's network gate (DESIGN §2,
// §10; docs/link_protocol.md). It uploads a mission — retransmitting it until ext_link acknowledges, so an
// upload made during the secure execution interval simply waits for MC — and prints the telemetry ext_link
// sends (MC only). Exit 0 when the upload was acknowledged (or, watching only, when telemetry arrived), 1
// when it was refused (a negative acknowledgement: the reason is printed), not acknowledged within --timeout
// (or no telemetry came), 2 on bad flags or a bad launch file.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/services/ext_link/link_protocol.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv::cli {
namespace {

constexpr std::chrono::milliseconds kHelloPeriod{1000};

// "N,E,D[,YAW];N,E,D[,YAW];…" (local NED [m], yaw [rad]).
Result<link::MissionUpload, std::string> parse_waypoints(std::string_view text) {
  link::MissionUpload up;
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
    if (index >= link::kMaxUploadWaypoints) {
      return fail("--waypoints: at most " + std::to_string(link::kMaxUploadWaypoints) + " waypoints");
    }
    up.waypoints[index++] = link::UploadWaypoint{
        .north_m = numbers[0], .east_m = numbers[1], .down_m = numbers[2], .yaw_rad = numbers.size() == 4 ? numbers[3] : 0.0};
  }
  if (index == 0) return fail("--waypoints: no waypoint given (expected N,E,D[,YAW];…)");
  up.count = static_cast<std::uint32_t>(index);
  return up;
}

Result<link::MissionUpload, std::string> mission_of_launch(const std::filesystem::path& path) {
  auto loaded = launch::load_launch(path);
  if (!loaded) return fail(loaded.error().to_string());
  const proto::Mission& m = loaded->graph.mission();
  if (m.waypoints_size() == 0) return fail("--upload: " + path.string() + " has no mission waypoints");
  if (static_cast<std::size_t>(m.waypoints_size()) > link::kMaxUploadWaypoints) {
    return fail("--upload: " + path.string() + " has " + std::to_string(m.waypoints_size()) + " waypoints; an upload holds at most " +
                std::to_string(link::kMaxUploadWaypoints));
  }
  link::MissionUpload up;
  up.count = static_cast<std::uint32_t>(m.waypoints_size());
  if (m.acceptance_radius_m() > 0) up.acceptance_radius_m = m.acceptance_radius_m();
  for (int i = 0; i < m.waypoints_size(); ++i) {
    const proto::Waypoint& w = m.waypoints(i);
    up.waypoints[static_cast<std::size_t>(i)] =
        link::UploadWaypoint{.north_m = w.north_m(), .east_m = w.east_m(), .down_m = w.down_m(), .yaw_rad = w.yaw_rad()};
  }
  return up;
}

const char* mode_text(std::uint8_t mode) {
  return mode < kModeCount ? mode_name(kAllModes[mode]) : "?";
}

}  // namespace

int run_gcs(std::span<const std::string_view> args) {
  std::optional<std::uint64_t> port;
  std::string host = "127.0.0.1";
  std::optional<std::filesystem::path> upload_path;
  std::optional<link::MissionUpload> waypoints;
  std::optional<double> radius, watch_s;
  double timeout_s = 60;
  bool all = false;
  Options opts("gcs",
               "A minimal ground control station for the kernel's network gate (UDP, docs/link_protocol.md).\n"
               "Uploads a mission to ext_link, retransmitting it every 200 ms until it is acknowledged (during\n"
               "the secure execution interval the gate drops everything, so the upload waits for MC), then\n"
               "prints the telemetry ext_link sends in MC. The kernel's port is in `rejuv run`'s log\n"
               "(\"network gate: udp 127.0.0.1:P\"; launch `network.bind_port`, default 14555).\n"
               "Exit 0 when the upload was acknowledged (watching only: when telemetry arrived), 1 when it\n"
               "was refused (the reason is printed: outside the geofence, below the altitude floor, too many\n"
               "waypoints) or not acknowledged in time, 2 on bad flags.");
  opts.integer("--port", "P", port, {1, 0xFFFF}, "the kernel's network gate port; required")
      .text("--host", "IP", host, "the kernel's address")
      .path("--upload", "LAUNCH_FILE", upload_path, "upload the mission of this launch graph")
      .custom<link::MissionUpload>("--waypoints", "N,E,D[,YAW];...", waypoints, parse_waypoints,
                                   "upload these waypoints (local NED [m], yaw [rad])")
      .real("--acceptance-radius", "M", radius, {.min = 0, .open_min = true},
            "acceptance radius of the uploaded mission [m]")
      .real("--watch", "SECONDS", watch_s, {.min = 0, .max = 1e6},
            "print telemetry for this long (after the upload is acknowledged)", "0 with an upload, 10 without")
      .real("--timeout", "SECONDS", timeout_s, {.min = 0.1, .max = 1e6}, "give up on the acknowledgement after this long")
      .flag("--all", all, "print every telemetry message (default: at most two lines a second)");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (!port) return bad_input("rejuv gcs: --port is required (the kernel's network gate port)");
  auto kernel = sys::UdpAddress::parse(host, static_cast<std::uint16_t>(*port));
  if (!kernel) return bad_input("rejuv gcs: --host: " + kernel.error());
  if (upload_path && waypoints) return bad_input("rejuv gcs: give --upload or --waypoints, not both");
  if (radius && !upload_path && !waypoints) {
    return bad_input("rejuv gcs: --acceptance-radius needs --upload or --waypoints");
  }

  std::optional<link::MissionUpload> upload = waypoints;
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
  // A new sequence per run, so that ext_link forwards an upload it has seen before (same waypoints).
  std::uint32_t sequence = static_cast<std::uint32_t>(start.count()) | 1U;
  const std::uint32_t upload_sequence = sequence++;
  const auto send = [&](const link::Message& m) {
    const link::Datagram d = link::encode(m);
    if (auto ok = socket->send_to(d.view(), *kernel); !ok) {
      std::fprintf(stderr, "rejuv gcs: %s\n", ok.error().to_string().c_str());
    }
  };

  if (upload) {
    std::printf("rejuv gcs: uploading %u waypoints to %s (retransmitted every 200 ms until acknowledged)\n",
                upload->count, kernel->to_string().c_str());
  } else {
    std::printf("rejuv gcs: watching telemetry from %s\n", kernel->to_string().c_str());
  }
  std::fflush(stdout);
  bool acked = !upload.has_value();
  std::optional<Nanos> acked_at = acked ? std::optional<Nanos>(start) : std::nullopt;
  std::uint64_t transmissions = 0, telemetry = 0, malformed = 0;
  Nanos next_upload = start, next_hello = start, last_print{0};
  std::array<std::byte, link::kMaxLinkDatagramBytes + 1> buf{};
  for (;;) {
    const Nanos now = sys::monotonic_now();
    if (!acked) {
      if (now - start >= timeout) {
        std::printf("rejuv gcs: no acknowledgement after %.1f s and %llu transmissions; giving up\n", elapsed(),
                    static_cast<unsigned long long>(transmissions));
        return static_cast<int>(Exit::Findings);
      }
      if (now >= next_upload) {
        send({.sequence = upload_sequence, .body = *upload});
        ++transmissions;
        next_upload = now + std::chrono::milliseconds{200};
      }
    } else if (now - *acked_at >= watch) {
      break;
    }
    if (now >= next_hello) {  // keeps telemetry coming (and says where to send it)
      send({.sequence = sequence++, .body = link::Hello{}});
      next_hello = now + kHelloPeriod;
    }
    const Nanos wake = acked ? std::min(next_hello, *acked_at + watch) : std::min(next_hello, next_upload);
    if (auto ready = sys::wait_fd(socket->fd(), sys::WaitFor::Readable, std::max(Nanos{0}, wake - now)); !ready) {
      return bad_input("rejuv gcs: " + ready.error().to_string());
    }
    for (;;) {
      auto r = socket->receive(buf);
      if (!r) break;  // EAGAIN: drained
      if (!(r->from == *kernel)) continue;  // not from the vehicle
      auto m = link::decode(std::span<const std::byte>(buf.data(), r->size), link::Direction::ToGround);
      if (!m || r->truncated) {
        ++malformed;
        continue;
      }
      if (const auto* ack = std::get_if<link::MissionAck>(&m->body)) {
        if (!acked && ack->upload_sequence == upload_sequence && ack->status == link::AckStatus::Refused) {
          // A negative acknowledgement: the upload is not a mission commander would keep; nothing changed.
          std::printf("rejuv gcs: upload refused by ext_link after %.1f s and %llu transmission(s): %s",
                      elapsed(), static_cast<unsigned long long>(transmissions),
                      std::string(link::to_string(ack->reason)).c_str());
          if (ack->reason == link::RefusalReason::OutsideGeofence ||
              ack->reason == link::RefusalReason::BelowAltitudeFloor) {
            const link::UploadWaypoint& w = upload->waypoints[ack->waypoint];
            std::printf(" (waypoint %u: N %.2f E %.2f D %.2f m)", ack->waypoint + 1U, w.north_m, w.east_m, w.down_m);
          }
          std::printf("; the vehicle flies on unchanged\n");
          std::fflush(stdout);
          return static_cast<int>(Exit::Findings);
        }
        if (!acked && ack->upload_sequence == upload_sequence) {
          acked = true;
          acked_at = sys::monotonic_now();
          std::printf("rejuv gcs: upload acknowledged by ext_link after %.1f s and %llu transmission(s)\n", elapsed(),
                      static_cast<unsigned long long>(transmissions));
          std::fflush(stdout);
        }
      } else if (const auto* t = std::get_if<link::Telemetry>(&m->body)) {
        ++telemetry;
        const Nanos at = sys::monotonic_now();
        if (!all && at - last_print < std::chrono::milliseconds{500}) continue;
        last_print = at;
        std::printf("t=%8.3f s  %s  p=(%6.2f, %6.2f, %6.2f) m  v=(%5.2f, %5.2f, %5.2f) m/s  sp=(%5.2f, %5.2f, %5.2f) "
                    "wp %u%s  epoch %u  security events %llu  link refused %llu  uploads %llu\n",
                    static_cast<double>(t->time_ns) * 1e-9, mode_text(t->sr_mode), t->p_N_m[0], t->p_N_m[1],
                    t->p_N_m[2], t->v_N_m_s[0], t->v_N_m_s[1], t->v_N_m_s[2], t->setpoint_N_m[0], t->setpoint_N_m[1],
                    t->setpoint_N_m[2], t->waypoint_index, t->mission_done != 0 ? " (mission done)" : "", t->epoch,
                    static_cast<unsigned long long>(t->security_events),
                    static_cast<unsigned long long>(t->link_refused),
                    static_cast<unsigned long long>(t->uploads_forwarded));
        std::fflush(stdout);
      }
    }
  }
  std::printf("rejuv gcs: %llu telemetry message(s)%s\n", static_cast<unsigned long long>(telemetry),
              malformed > 0 ? (", " + std::to_string(malformed) + " malformed datagram(s) ignored").c_str() : "");
  const bool good = upload ? acked : telemetry > 0;
  return static_cast<int>(good ? Exit::Ok : Exit::Findings);
}

}  // namespace rejuv::cli
