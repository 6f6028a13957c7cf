// One end of `rejuv bench across-hosts` (bench_across_hosts.cpp in tools/rejuv): one Cyclone DDS participant, run
// in a network namespace with `ip netns exec`, configured by the Cyclone XML the benchmark wrote (its interface,
// both hosts as unicast peers and, with DDS Security, the enclave `rejuv keys hosts` made). Cyclone's C API on
// its own: the raw baseline the kernel's path is compared with.
//   publish TOPIC:   waits until a reader matched, then writes --warmup samples stamped 0 and --samples samples
//                    stamped with CLOCK_MONOTONIC at the write, one every 1/--rate-hz s (absolute deadlines),
//                    then waits for their acknowledgements. Prints "writing", then "wrote N".
//   subscribe TOPIC: prints "reading" once its reader exists; takes samples on a waitset (woken by data) and,
//                    for each one stamped, writes CLOCK_MONOTONIC now − stamp [ns] as a line of --out, until
//                    --samples arrived or --seconds passed. Prints "received N".
// CLOCK_MONOTONIC is one clock for every network namespace of a machine, so the difference is the one-way
// publish → deliver latency. The sample is rejuv::msg::VehicleStateEstimate (idl/state.idl): its timestamp_ns
// (the first field) carries the stamp.
// Usage: rejuv_dds_latency_peer publish|subscribe TOPIC --domain N --config FILE --samples N [--warmup N]
//        [--rate-hz R] [--seconds S] [--out FILE]
#include <dds/dds.h>
#include <time.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "rejuv/msgs/topic_types.hpp"

namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;

std::int64_t monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * kNsPerS + ts.tv_nsec;
}

void sleep_until(std::int64_t t_ns) {
  const timespec ts{.tv_sec = t_ns / kNsPerS, .tv_nsec = t_ns % kNsPerS};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) != 0) {
  }
}

int refused(const char* call, dds_return_t rc) {
  std::printf("refused: %s: %s\n", call, dds_strretcode(rc));
  std::fflush(stdout);
  return 3;
}

struct Args {
  std::string role, topic, config_file, out_file;
  unsigned domain = 0;
  std::uint64_t samples = 0, warmup = 25;
  double rate_hz = 250, seconds = 120;
};

bool parse(int argc, char** argv, Args& a) {
  if (argc < 3) return false;
  a.role = argv[1];
  a.topic = argv[2];
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const char* v = argv[i + 1];
    if (flag == "--domain") a.domain = static_cast<unsigned>(std::strtoul(v, nullptr, 10));
    else if (flag == "--config") a.config_file = v;
    else if (flag == "--samples") a.samples = std::strtoull(v, nullptr, 10);
    else if (flag == "--warmup") a.warmup = std::strtoull(v, nullptr, 10);
    else if (flag == "--rate-hz") a.rate_hz = std::strtod(v, nullptr);
    else if (flag == "--seconds") a.seconds = std::strtod(v, nullptr);
    else if (flag == "--out") a.out_file = v;
    else return false;
  }
  if ((argc - 3) % 2 != 0) return false;
  return (a.role == "publish" || a.role == "subscribe") && !a.config_file.empty() && a.samples > 0 &&
         a.rate_hz > 0 && a.seconds > 0 && (a.role == "publish" || !a.out_file.empty());
}

int publish(const Args& a, dds_entity_t participant, dds_entity_t topic, dds_qos_t* qos, void* sample) {
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  if (writer < 0) return refused("dds_create_writer", writer);
  std::printf("writing\n");
  std::fflush(stdout);
  // The secure handshake takes a while: write nothing before the reader is there (volatile samples are lost).
  const std::int64_t match_deadline = monotonic_ns() + static_cast<std::int64_t>(a.seconds * kNsPerS);
  for (;;) {
    dds_publication_matched_status_t m{};
    if (dds_get_publication_matched_status(writer, &m) == 0 && m.current_count > 0) break;
    if (monotonic_ns() > match_deadline) {
      std::printf("no reader matched\n");
      return 4;
    }
    sleep_until(monotonic_ns() + 1'000'000);
  }
  const auto period = static_cast<std::int64_t>(kNsPerS / a.rate_hz);
  std::int64_t next = monotonic_ns() + period;
  std::uint64_t wrote = 0;
  for (std::uint64_t i = 0; i < a.warmup + a.samples; ++i, next += period) {
    sleep_until(next);
    const std::uint64_t stamp = i < a.warmup ? 0 : static_cast<std::uint64_t>(monotonic_ns());
    std::memcpy(sample, &stamp, sizeof stamp);
    if (const dds_return_t w = dds_write(writer, sample); w < 0) {
      std::fprintf(stderr, "dds_write: %s\n", dds_strretcode(w));
    } else if (i >= a.warmup) {
      ++wrote;
    }
  }
  (void)dds_wait_for_acks(writer, DDS_SECS(5));
  std::printf("wrote %llu\n", static_cast<unsigned long long>(wrote));
  std::fflush(stdout);
  return 0;
}

int subscribe(const Args& a, dds_entity_t participant, dds_entity_t topic, dds_qos_t* qos, void* sample) {
  const dds_entity_t reader = dds_create_reader(participant, topic, qos, nullptr);
  if (reader < 0) return refused("dds_create_reader", reader);
  const dds_entity_t waitset = dds_create_waitset(participant);
  const dds_entity_t readable = dds_create_readcondition(reader, DDS_ANY_STATE);
  if (waitset < 0 || readable < 0 || dds_waitset_attach(waitset, readable, 0) < 0) return refused("waitset", waitset);
  std::printf("reading\n");
  std::fflush(stdout);
  std::vector<std::int64_t> latencies;
  latencies.reserve(a.samples);
  const dds_time_t deadline = dds_time() + static_cast<dds_duration_t>(a.seconds * kNsPerS);
  while (latencies.size() < a.samples) {
    if (dds_waitset_wait_until(waitset, nullptr, 0, deadline) <= 0) break;  // the deadline passed
    for (;;) {
      void* samples[1] = {sample};
      dds_sample_info_t info{};
      const dds_return_t got = dds_take(reader, samples, &info, 1, 1);
      if (got <= 0) break;
      const std::int64_t now = monotonic_ns();
      std::uint64_t stamp = 0;
      std::memcpy(&stamp, sample, sizeof stamp);
      if (info.valid_data && stamp != 0) latencies.push_back(now - static_cast<std::int64_t>(stamp));
    }
  }
  std::ofstream out(a.out_file);
  for (const std::int64_t ns : latencies) out << ns << '\n';
  std::printf("received %zu\n", latencies.size());
  std::fflush(stdout);
  return out ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!parse(argc, argv, a)) {
    std::fprintf(stderr,
                 "usage: rejuv_dds_latency_peer publish|subscribe TOPIC --domain N --config FILE --samples N "
                 "[--warmup N] [--rate-hz R] [--seconds S] [--out FILE (subscribe)]\n");
    return 2;
  }
  std::ifstream in(a.config_file);
  std::stringstream config;
  config << in.rdbuf();
  if (!in) {
    std::fprintf(stderr, "rejuv_dds_latency_peer: cannot read %s\n", a.config_file.c_str());
    return 2;
  }
  const rejuv::msgs::TopicType* type = rejuv::msgs::find_topic_type("rejuv::msg::VehicleStateEstimate");
  if (type == nullptr) return 2;
  const dds_entity_t dom = dds_create_domain(a.domain, config.str().c_str());
  if (dom < 0) return refused("dds_create_domain", dom);
  const dds_entity_t participant = dds_create_participant(a.domain, nullptr, nullptr);
  if (participant < 0) return refused("dds_create_participant", participant);
  const dds_entity_t topic = dds_create_topic(participant, type->descriptor, a.topic.c_str(), nullptr, nullptr);
  if (topic < 0) return refused("dds_create_topic", topic);
  // The kernel bridge's QoS (rejuv/dds/dds.hpp): reliable, keep-last, volatile.
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 16);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  // A zeroed payload of the type's size, aligned for any field.
  std::vector<std::max_align_t> buffer(type->size / sizeof(std::max_align_t) + 1);
  std::memset(buffer.data(), 0, buffer.size() * sizeof(std::max_align_t));
  const int rc = a.role == "publish" ? publish(a, participant, topic, qos, buffer.data())
                                     : subscribe(a, participant, topic, qos, buffer.data());
  dds_delete_qos(qos);
  dds_delete(dom);
  return rc;
}
