// The link's row of `rejuv bench across-hosts` (bench_across_hosts.cpp): two SDK services of one executable on two
// hosts, each under its own `rejuv run --host` kernel, so that a sample goes service → kernel → link (rejuv_host_link)
// → DDS with DDS Security → link → kernel → service, the whole path of a cross-host topic.
//   on the vehicle (REJUV_LINK_PROBE_PUBLISH): publishes `link_probe` (rejuv::msg::VehicleStateEstimate, 216 B)
//     every 4 ms of kernel time, its timestamp_ns the CLOCK_MONOTONIC of the write;
//   on the companion: for each one received, CLOCK_MONOTONIC now − timestamp_ns [ns], one clock for every network
//     namespace of a machine; once a second it logs every latency it has not logged yet:
//     "link probe latencies [ns]: 812345 790123 …" (the benchmark collects them from the kernel's log).
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
    std::vector<std::int64_t> pending;
    pending.reserve(512);
    auto in = svc.subscribe<rejuv_msg_VehicleStateEstimate>("link_probe", [&](const rejuv_msg_VehicleStateEstimate& s) {
      pending.push_back(monotonic_ns() - static_cast<std::int64_t>(s.timestamp_ns));
    });
    if (!svc.require(in, "link_probe")) return 1;
    auto report = svc.every(std::chrono::seconds(1), [&] {
      // In lines of at most 40 values, well inside a log line.
      for (std::size_t at = 0; at < pending.size(); at += 40) {
        std::string line;
        for (std::size_t i = at; i < pending.size() && i < at + 40; ++i) line += " " + std::to_string(pending[i]);
        svc.logf(sdk::LogLevel::Info, "link probe latencies [ns]:%s", line.c_str());
      }
      pending.clear();
    });
    if (!svc.require(report, "report timer")) return 1;
#endif
    return svc.run();
  });
}
