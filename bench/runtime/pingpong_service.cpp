// The two services of the kernel-path latency benchmark (bench/runtime): `pong` echoes every message of
// topic "ping" on topic "pong"; `ping` sends one message, waits for its echo, records the round-trip time
// and sends the next. A benchmark service may read the monotonic clock (it measures; no flight service
// does). The round-trip times go back to the benchmark process — the kernel — on topic "results" after the
// last one, so that nothing but the ping-pong itself crosses the kernel while it is timed.
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "rejuv/sdk/service.hpp"

namespace {

using rejuv::sdk::LogLevel;
using rejuv::sdk::Service;
using Clock = std::chrono::steady_clock;

template <class T>
int run_pong(Service& svc) {
  auto out = svc.advertise<T>("pong");
  if (!out) {
    svc.log(LogLevel::Error, out.error().to_string());
    return 3;
  }
  auto in = svc.subscribe<T>("ping", [&](const T& m) { (void)out->publish(m); });
  if (!in) {
    svc.log(LogLevel::Error, in.error().to_string());
    return 3;
  }
  return svc.run();
}

template <class T>
int run_ping(Service& svc) {
  const auto warmup = static_cast<std::uint64_t>(svc.param("warmup", 200));
  const auto count = static_cast<std::uint64_t>(svc.param("count", 5000));
  auto ping = svc.advertise<T>("ping");
  auto results = svc.advertise<rejuv_msg_MissionWaypoints>("results");
  if (!ping || !results) {
    svc.log(LogLevel::Error, "advertise failed");
    return 3;
  }
  std::vector<std::int64_t> rtt_ns;
  rtt_ns.reserve(count);
  std::uint64_t seq = 0;
  Clock::time_point sent_at;
  const auto send = [&] {
    T m{};
    std::memcpy(&m, &seq, sizeof(seq));
    sent_at = Clock::now();
    (void)ping->publish(m);
  };
  const auto report = [&] {
    rejuv_msg_MissionWaypoints batch{};
    for (std::size_t i = 0; i < rtt_ns.size(); ++i) {
      batch.waypoints[batch.count].p_N_m[0] = static_cast<double>(rtt_ns[i]);
      if (++batch.count == 16) {
        (void)results->publish(batch);
        batch = rejuv_msg_MissionWaypoints{};
      }
    }
    if (batch.count > 0) (void)results->publish(batch);
    batch = rejuv_msg_MissionWaypoints{};
    batch.acceptance_radius_m = -1;  // end marker
    (void)results->publish(batch);
  };
  auto pong = svc.subscribe<T>("pong", [&](const T& m) {
    const auto now = Clock::now();
    std::uint64_t got = 0;
    std::memcpy(&got, &m, sizeof(got));
    if (got != seq) return;  // not ours (a stale echo)
    if (seq >= warmup) rtt_ns.push_back(std::chrono::duration_cast<std::chrono::nanoseconds>(now - sent_at).count());
    if (++seq < warmup + count) {
      send();
    } else {
      report();
    }
  });
  if (!pong) {
    svc.log(LogLevel::Error, pong.error().to_string());
    return 3;
  }
  auto start = svc.after(std::chrono::milliseconds{50}, send);
  if (!start) return 3;
  return svc.run();
}

template <class T>
int run_role(Service& svc, const std::string& role) {
  if (role == "ping") return run_ping<T>(svc);
  if (role == "pong") return run_pong<T>(svc);
  svc.log(LogLevel::Error, "unknown role " + role);
  return 3;
}

}  // namespace

int main() {
  auto svc = Service::connect();
  if (!svc) return rejuv::sdk::report_connect_failure(svc.error());
  Service& s = **svc;
  const std::string role(s.text_param("role", ""));
  const std::string type(s.text_param("type", ""));
  if (type == "rejuv::msg::ActuatorOutputs") return run_role<rejuv_msg_ActuatorOutputs>(s, role);
  if (type == "rejuv::msg::GroundTruth") return run_role<rejuv_msg_GroundTruth>(s, role);
  if (type == "rejuv::msg::VehicleStateEstimate") return run_role<rejuv_msg_VehicleStateEstimate>(s, role);
  s.log(LogLevel::Error, "unknown type " + type);
  return 3;
}
