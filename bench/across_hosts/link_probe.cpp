// The link rows of `rejuv bench across-hosts` (bench_across_hosts.cpp): two SDK services of one executable on two
// hosts, each under its own `rejuv run --host` kernel, so that a sample goes service → kernel → link
// (rejuv_host_link) → DDS with DDS Security → link → kernel → service, the whole path of a cross-host topic.
//   on the vehicle (REJUV_LINK_PROBE_PUBLISH): publishes `link_probe` (rejuv::msg::VehicleStateEstimate, 216 B)
//     every 4 ms of kernel time, its timestamp_ns the CLOCK_MONOTONIC of the write;
//   on the companion: for each one received, CLOCK_MONOTONIC now − timestamp_ns [ns], one clock for every network
//     namespace of a machine; once a second it logs every latency it has not logged yet, and the CLOCK_MONOTONIC
//     at which each of those samples was received, in the same order:
//     "link probe latencies [ns]: 812345 790123 …", "link probe received [ns]: 67212143138000 67212147139000 …"
//     (the benchmark collects them from the kernel's log and pairs them in order).
#include <time.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"

namespace {

std::int64_t monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);  // the vDSO: no system call for the filter to see
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

int main() {
  using namespace rejuv;
  return sdk::run_service([](sdk::Service& svc) {
#if defined(REJUV_LINK_PROBE_PUBLISH)
    auto out = svc.advertise<rejuv_msg_VehicleStateEstimate>("link_probe");
    if (!svc.require(out, "link_probe")) return 1;
    auto tick = svc.every(std::chrono::milliseconds(4), [&] {
      rejuv_msg_VehicleStateEstimate s{};
      s.timestamp_ns = static_cast<std::uint64_t>(monotonic_ns());
      (void)out->publish(s);  // refused outside MC (the grant's modes): nothing to measure then
    });
    if (!svc.require(tick, "probe timer")) return 1;
#else
    std::vector<std::int64_t> latencies, received;
    latencies.reserve(512);
    received.reserve(512);
    auto in = svc.subscribe<rejuv_msg_VehicleStateEstimate>("link_probe", [&](const rejuv_msg_VehicleStateEstimate& s) {
      const std::int64_t now = monotonic_ns();
      latencies.push_back(now - static_cast<std::int64_t>(s.timestamp_ns));
      received.push_back(now);
    });
    if (!svc.require(in, "link_probe")) return 1;
    // In lines of at most 40 values, well inside a log line and, two lines per 40 samples at 250 Hz, inside the
    // kernel's rate limit of a service's log (20 lines a second).
    const auto log_values = [&svc](const char* what, const std::vector<std::int64_t>& values) {
      for (std::size_t at = 0; at < values.size(); at += 40) {
        std::string line;
        for (std::size_t i = at; i < values.size() && i < at + 40; ++i) line += " " + std::to_string(values[i]);
        svc.logf(sdk::LogLevel::Info, "link probe %s [ns]:%s", what, line.c_str());
      }
    };
    auto report = svc.every(std::chrono::seconds(1), [&] {
      log_values("latencies", latencies);
      log_values("received", received);
      latencies.clear();
      received.clear();
    });
    if (!svc.require(report, "report timer")) return 1;
#endif
    return svc.run();
  });
}
