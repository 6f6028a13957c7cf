// Capability kernel benchmarks (docs/design.md §3, §11): the broker's hot path (decode of a Publish, target
// ≤ 50 ns on a 256-slot CSpace), the denial path with its audit-log append, and a full Fig. 1 cycle of
// apply_mode on a table the size of the real policy. Timings live here, never in tests.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/cap/cap_system.hpp"

namespace rejuv::cap {
namespace {

// A synthetic table shaped like policies/ (9 services, 25 objects, ~60 policy slots): topics read
// everywhere and written by one service, the network only in MC, checkpoint and limits only outside
// MC, persistent cells and the mode object for checkpoint_p. Rights vary by mode the way §III demands,
// so each transition replaces a realistic share of slots.
ModeTable synthetic_policy() {
  ModeTable t;
  t.services = {"sensors",       "ekf2",         "lqr_control",   "safety_control", "gen_set_point",
                "commander",     "checkpoint_p", "output_driver", "ext_link"};
  const auto add = [&](ObjectKind kind, std::string name) {
    const ObjectId id{static_cast<std::uint32_t>(t.objects.size())};
    t.objects.push_back({.id = id, .kind = kind, .name = std::move(name)});
    return id;
  };
  std::vector<std::uint32_t> next_slot(t.services.size(), 0);
  const auto grant = [&](std::uint32_t service, ObjectId object, std::array<Rights, kModeCount> rights) {
    t.slots.push_back({.service = ServiceId{service}, .slot = Slot{next_slot[service]++}, .object = object, .rights = rights});
  };
  const Rights r = Right::Read;
  const Rights w = Right::Write;
  const Rights none = Rights::none();
  const std::array<Rights, kModeCount> always_r{r, r, r, r, r};
  const std::array<Rights, kModeCount> always_w{w, w, w, w, w};
  const std::array<Rights, kModeCount> mc_only_w{w, none, none, none, none};        // MC RB SC Update CP
  const std::array<Rights, kModeCount> sc_only_w{none, none, w, w, w};
  const std::array<Rights, kModeCount> sei_w{none, w, w, w, w};
  const std::array<Rights, kModeCount> mc_rw{r | w, none, none, none, none};

  // 20 topics: each written by one service in its modes, read by two others.
  for (std::uint32_t i = 0; i < 20; ++i) {
    const ObjectId topic = add(ObjectKind::Topic, "topic" + std::to_string(i));
    const std::uint32_t writer = i % 9;
    grant(writer, topic, i % 4 == 2 ? mc_only_w : (i % 4 == 3 ? sc_only_w : always_w));
    grant((writer + 1) % 9, topic, always_r);
    grant((writer + 4) % 9, topic, i % 2 == 0 ? always_r : std::array<Rights, kModeCount>{r, none, r, r, r});
  }
  const ObjectId net = add(ObjectKind::Network, "net");
  const ObjectId ckpt = add(ObjectKind::Checkpoint, "ckpt");
  const ObjectId limits = add(ObjectKind::Limits, "limits");
  const ObjectId cell = add(ObjectKind::Persistent, "cell");
  const ObjectId mode = add(ObjectKind::Mode, "mode");
  grant(8, net, mc_rw);                       // ext_link: network only in MC (§III SEI)
  grant(6, ckpt, sei_w);                      // checkpoint_p: no Checkpoint right in MC (§III timer)
  grant(6, limits, sc_only_w);                // checkpoint_p writes Ū outside MC (§IV-C)
  grant(7, limits, always_r);                 // output_driver applies them
  grant(6, cell, std::array<Rights, kModeCount>{r, r | w, r | w, r | w, r | w});
  grant(6, mode, always_w);
  return t;
}

CapSystem make_system(const ModeTable& table) {
  auto sys = CapSystem::create(table, {.cspace_slots = 256, .audit_capacity = 4096, .initial_mode = SrMode::MC});
  if (!sys) {
    std::abort();
  }
  return std::move(*sys);
}

// The broker's hot path: every publication is decoded against the sender's CSpace.
void BM_DecodePublish(benchmark::State& state) {
  const ModeTable table = synthetic_policy();
  CapSystem sys = make_system(table);
  const ServiceId sender{0};
  const Slot slot{0};  // sensors' write cap on topic0
  for (auto _ : state) {
    auto inv = sys.decode(sender, slot, Operation::Publish);
    benchmark::DoNotOptimize(inv);
  }
  if (!sys.decode(sender, slot, Operation::Publish)) {
    state.SkipWithError("publish was denied");
  }
}
BENCHMARK(BM_DecodePublish);

// Baseline for the line above, side by side: the least any check can cost here — an out-of-line call
// doing one bounds-checked load from a 256-entry table and returning an optional.
struct BaselineSlot {
  std::uint32_t object;
  std::uint8_t rights;
  bool occupied;
};
[[gnu::noinline]] std::optional<std::uint32_t> baseline_lookup(const std::vector<BaselineSlot>& slots, std::uint32_t i) {
  if (i >= slots.size() || !slots[i].occupied || (slots[i].rights & 2U) == 0) {
    return std::nullopt;
  }
  return slots[i].object;
}
void BM_BaselineBoundsCheckedLoad(benchmark::State& state) {
  const std::vector<BaselineSlot> slots(256, BaselineSlot{.object = 7, .rights = 3, .occupied = true});
  std::uint32_t i = 0;
  benchmark::DoNotOptimize(i);
  for (auto _ : state) {
    auto r = baseline_lookup(slots, i);
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_BaselineBoundsCheckedLoad);

// The router's check at every delivery (router.cpp deliver_one): the subscriber's cap looked up and its Read in
// the current mode tested. Beside BM_BaselineBoundsCheckedLoad above.
void BM_DeliveryReadCheck(benchmark::State& state) {
  const ModeTable table = synthetic_policy();
  CapSystem sys = make_system(table);
  const CapRef cap{.space = ServiceId{1}, .slot = Slot{0}};
  for (auto _ : state) {
    const auto held = sys.lookup(cap);
    const bool readable = held && held->rights.has(Right::Read);
    benchmark::DoNotOptimize(readable);
  }
  const auto held = sys.lookup(cap);
  if (!held || !held->rights.has(Right::Read)) state.SkipWithError("the subscriber holds no Read");
}
BENCHMARK(BM_DeliveryReadCheck);

// Rotating over every policy slot of every service: the same path with cold-ish branches.
void BM_DecodeRotating(benchmark::State& state) {
  const ModeTable table = synthetic_policy();
  CapSystem sys = make_system(table);
  std::size_t i = 0;
  for (auto _ : state) {
    const SlotGrant& g = table.slots[i];
    i = i + 1 == table.slots.size() ? 0 : i + 1;
    auto inv = sys.decode(g.service, g.slot, Operation::Subscribe);
    benchmark::DoNotOptimize(inv);
  }
}
BENCHMARK(BM_DecodeRotating);

// A denial: an empty slot, counted and appended to the (wrapping) audit ring.
void BM_DecodeDeniedEmptySlot(benchmark::State& state) {
  const ModeTable table = synthetic_policy();
  CapSystem sys = make_system(table);
  for (auto _ : state) {
    auto inv = sys.decode(ServiceId{0}, Slot{200}, Operation::Publish);
    benchmark::DoNotOptimize(inv);
  }
  state.counters["audit_overwritten"] = static_cast<double>(sys.audit_log().overwritten());
}
BENCHMARK(BM_DecodeDeniedEmptySlot);

// One full CPS SR cycle of policy transitions (Fig. 1): MC → RB → SC → Update → CP → MC.
void BM_ApplyModeCycle(benchmark::State& state) {
  const ModeTable table = synthetic_policy();
  CapSystem sys = make_system(table);
  std::size_t changed = 0;
  for (auto _ : state) {
    for (const SrMode m : {SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP, SrMode::MC}) {
      auto change = sys.apply_mode(m);
      benchmark::DoNotOptimize(change);
      changed += change ? change->slots_changed : 0;
    }
  }
  state.counters["slots_changed_per_cycle"] =
      benchmark::Counter(static_cast<double>(changed), benchmark::Counter::kAvgIterations);
  state.counters["policy_slots"] = static_cast<double>(table.slots.size());
  state.counters["objects"] = static_cast<double>(table.objects.size());
}
BENCHMARK(BM_ApplyModeCycle);

}  // namespace
}  // namespace rejuv::cap

BENCHMARK_MAIN();
