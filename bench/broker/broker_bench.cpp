// Broker benchmarks (docs/design.md §5, §7, §11). Timings live here, never in tests.
//  - BM_PublishFanout: the routing hot path — publish one 96-byte message on a topic with 3 subscribers and
//    read it out for each of them (what the kernel does per publication before pushing to the channels).
//  - BM_Snapshot / BM_Restore / BM_CheckpointRollback: the queue state's share of the checkpoint and
//    rollback latency (docs/design.md §7 step 3; target for the whole checkpoint ≤ 0.5 ms), on a broker shaped like
//    launch/quad_square_paper: 18 topics, depth 4–8, payloads 40–600 bytes, 35 subscriptions.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <vector>

#include "rejuv/broker/broker.hpp"

namespace rejuv::broker {
namespace {

// Sizes close to the IDL structs of idl/*.idl (doubles plus a uint64 timestamp); the mission (16 waypoints)
// is the largest. Depths: fast sensor streams 8, the rest 4.
struct Shape {
  const char* name;
  std::size_t size;
  std::uint32_t depth;
  std::uint32_t subscribers;  // how many services read it
  std::uint32_t drivers;      // of which driver level (output_driver)
};
constexpr Shape kGraph[] = {
    {"sensor_gyro", 40, 8, 1, 0},       {"sensor_accel", 40, 8, 1, 0},
    {"sensor_mag", 40, 4, 2, 0},        {"sensor_baro", 48, 4, 2, 0},
    {"sensor_gps", 80, 4, 2, 0},        {"sensor_combined", 72, 8, 1, 0},
    {"vehicle_state", 200, 8, 6, 0},    {"ground_truth", 112, 8, 1, 0},
    {"actuator_controls", 48, 8, 2, 1}, {"actuator_outputs", 40, 8, 1, 0},
    {"setpoint", 48, 4, 5, 0},          {"mission", 600, 4, 1, 0},
    {"mission_upload", 600, 4, 1, 0},   {"sr_mode", 40, 4, 3, 1},
    {"rollback_signal", 40, 4, 1, 0},   {"setpoint_update_request", 40, 4, 1, 0},
    {"security_event", 96, 8, 2, 0},    {"actuator_limits", 64, 4, 2, 1},
};

Broker make_graph(std::size_t& subscriptions) {
  std::vector<TopicConfig> config;
  for (std::uint32_t i = 0; i < std::size(kGraph); ++i) {
    config.push_back({.object = ObjectId{i},
                      .name = kGraph[i].name,
                      .payload_size = kGraph[i].size,
                      .depth = kGraph[i].depth});
  }
  auto created = Broker::create(config);
  if (!created) {
    std::abort();
  }
  Broker b = std::move(*created);
  subscriptions = 0;
  for (std::uint32_t i = 0; i < std::size(kGraph); ++i) {
    for (std::uint32_t k = 0; k < kGraph[i].subscribers; ++k) {
      const bool driver = k < kGraph[i].drivers;
      const ServiceId service{driver ? 7U : (i + k) % 7U};
      if (!b.subscribe(service, ObjectId{i}, driver ? SubscriberKind::Driver : SubscriberKind::Rejuvenated)) {
        std::abort();
      }
      ++subscriptions;
    }
    // Fill every ring, so that the snapshot copies real messages.
    const std::vector<std::byte> payload(kGraph[i].size, std::byte{0x5A});
    for (std::uint32_t n = 0; n < 2 * kGraph[i].depth; ++n) {
      if (!b.publish(ObjectId{i}, payload, Nanos{n})) {
        std::abort();
      }
    }
  }
  return b;
}

void BM_PublishFanout(benchmark::State& state) {
  const ObjectId topic{0};
  auto created = Broker::create(
      std::vector<TopicConfig>{{.object = topic, .name = "vehicle_state", .payload_size = 96, .depth = 8}});
  if (!created) {
    std::abort();
  }
  Broker b = std::move(*created);
  const SubscriberId a = *b.subscribe(ServiceId{1}, topic, SubscriberKind::Rejuvenated);
  const SubscriberId c = *b.subscribe(ServiceId{2}, topic, SubscriberKind::Rejuvenated);
  const SubscriberId d = *b.subscribe(ServiceId{7}, topic, SubscriberKind::Driver);
  std::vector<std::byte> payload(96, std::byte{1});
  std::int64_t t = 0;
  for (auto _ : state) {
    payload[0] = static_cast<std::byte>(t);
    auto g = b.publish(topic, payload, Nanos{++t});
    benchmark::DoNotOptimize(g);
    for (const SubscriberId s : {a, c, d}) {
      auto m = b.next(s);
      benchmark::DoNotOptimize(m);
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PublishFanout);

void BM_Snapshot(benchmark::State& state) {
  std::size_t subscriptions = 0;
  const Broker b = make_graph(subscriptions);
  BrokerSnapshot cp;
  b.snapshot_into(cp);  // the first checkpoint allocates; every later one reuses
  for (auto _ : state) {
    b.snapshot_into(cp);
    benchmark::DoNotOptimize(cp);
  }
  state.counters["bytes"] = static_cast<double>(cp.size_bytes());
  state.counters["subscriptions"] = static_cast<double>(subscriptions);
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(cp.size_bytes()));
}
BENCHMARK(BM_Snapshot)->Unit(benchmark::kMicrosecond);

void BM_Restore(benchmark::State& state) {
  std::size_t subscriptions = 0;
  Broker b = make_graph(subscriptions);
  const BrokerSnapshot cp = b.snapshot();
  for (auto _ : state) {
    auto r = b.restore(cp);
    benchmark::DoNotOptimize(r);
  }
  state.counters["bytes"] = static_cast<double>(cp.size_bytes());
}
BENCHMARK(BM_Restore)->Unit(benchmark::kMicrosecond);

// One SR cycle's share of the queue state: checkpoint, a few publications, rollback.
void BM_CheckpointRollback(benchmark::State& state) {
  std::size_t subscriptions = 0;
  Broker b = make_graph(subscriptions);
  BrokerSnapshot cp;
  b.snapshot_into(cp);
  const std::vector<std::byte> state_msg(kGraph[6].size, std::byte{7});
  for (auto _ : state) {
    b.snapshot_into(cp);
    for (int i = 0; i < 4; ++i) {
      auto g = b.publish(ObjectId{6}, state_msg, Nanos{i});
      benchmark::DoNotOptimize(g);
    }
    auto r = b.restore(cp);
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_CheckpointRollback)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rejuv::broker

BENCHMARK_MAIN();
