// "Publish and delivery never allocate" (docs/design.md §5), and a checkpoint after the first one reuses its storage
// (docs/design.md §7 latency budget). Counted by replacing the global allocation functions in this test binary: the
// one place where a mutable global is the point — it is the allocator itself.
#include <gtest/gtest.h>

#include <cstdlib>
#include <new>

#include "broker_fixture.hpp"

// The replaced operator delete frees what the replaced operator new took from malloc: GCC, inlining both in a
// sanitizer build, reports the pair as mismatched.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace {
thread_local std::size_t g_allocations = 0;  // allocations made by this thread
}  // namespace

void* operator new(std::size_t size) {
  ++g_allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) {
    return p;
  }
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  return ::operator new(size);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}

namespace rejuv::broker {
namespace {

using namespace rejuv::broker::testing;

// Allocations made by `f` on this thread.
template <class F>
std::size_t allocations_in(F&& f) {
  const std::size_t before = g_allocations;
  f();
  return g_allocations - before;
}

// Keeps the optimiser from eliding an allocation whose result is otherwise unused.
void escape(const void* p) {
  asm volatile("" : : "g"(p) : "memory");
}

// A broker shaped for these tests with two subscribers on one topic and a driver on another.
struct Loaded {
  Broker broker = make_broker();
  SubscriberId ekf2 = subscribe_ok(broker, kEkf2, kState);
  SubscriberId lqr = subscribe_ok(broker, kLqr, kState);
  SubscriberId driver = subscribe_ok(broker, kDriver, kGyro, SubscriberKind::Driver);
  std::vector<std::byte> state = payload(kStateSize, 1);
};

TEST(BrokerAlloc, Probe_VectorAllocation_Counted) {
  EXPECT_GE(allocations_in([] {
              std::vector<int> v(100);
              escape(v.data());
            }),
            1U);
}

TEST(BrokerAlloc, PublishAndNext_Warm_NoAllocation) {
  Loaded l;
  const std::size_t n = allocations_in([&] {
    for (std::uint32_t i = 0; i < 3 * kStateDepth; ++i) {  // laps the ring: overrun path included
      EXPECT_TRUE(l.broker.publish(kState, l.state, Nanos{i}).has_value());
      EXPECT_TRUE(l.broker.next(l.ekf2).has_value());
    }
    EXPECT_TRUE(l.broker.next(l.lqr).has_value());
    EXPECT_TRUE(l.broker.pending(l.lqr).has_value());
    EXPECT_TRUE(l.broker.subscribers_of(kState).has_value());
  });
  EXPECT_EQ(n, 0U);
}

TEST(BrokerAlloc, SnapshotInto_SecondTime_NoAllocation) {
  Loaded l;
  BrokerSnapshot cp;
  l.broker.snapshot_into(cp);
  EXPECT_TRUE(l.broker.publish(kState, l.state, Nanos{0}).has_value());
  EXPECT_EQ(allocations_in([&] { l.broker.snapshot_into(cp); }), 0U);
}

TEST(BrokerAlloc, Restore_SameSubscriptions_NoAllocation) {
  Loaded l;
  const BrokerSnapshot cp = l.broker.snapshot();
  EXPECT_TRUE(l.broker.publish(kState, l.state, Nanos{0}).has_value());
  EXPECT_EQ(allocations_in([&] { EXPECT_TRUE(l.broker.restore(cp).has_value()); }), 0U);
}

}  // namespace
}  // namespace rejuv::broker
