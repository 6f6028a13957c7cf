// The router's parts as owners of their state (kernel_sim/kernel/src; docs/design.md §5, §6; docs/protocol.md
// "Delivery and flow control", "Idle"): FlowControl, one service's delivery order, control pool, held frame
// and frame count; OutputBatch, the router's cork, over a real socket pair; CanonicalStage, the lockstep
// staging that hands messages out in canonical order; KernelMessage, the kernel's own messages with their
// padding zeroed.
#include <gtest/gtest.h>

#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "canonical_stage.hpp"
#include "output_batch.hpp"
#include "router.hpp"
#include "rejuv/channel/transport.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/sys/channel.hpp"
#include "service_runtime.hpp"

namespace rejuv::kernel {
namespace {

using broker::SubscriberId;

// A Log frame whose text is `text_bytes` bytes of `fill`: the frame's header says its length, which is all
// the batch and the flow control read of it.
std::vector<std::byte> frame(std::size_t text_bytes, char fill) {
  wire::FrameBuffer f;
  const std::vector<char> text(text_bytes, fill);
  EXPECT_TRUE(f.build_with(wire::FrameKind::Log, 0, 0, 0, wire::LogHeader{}, std::as_bytes(std::span(text))));
  return {f.bytes().begin(), f.bytes().end()};
}

std::vector<std::byte> bytes_of(std::span<const std::byte> s) {
  return {s.begin(), s.end()};
}

// What FlowControl::pop handed out, as text: "r<subscriber>" for a ring entry, "c<first byte>" for a control
// frame.
std::vector<std::string> pop_all(FlowControl& flow) {
  std::vector<std::string> out;
  while (flow.pop([&](SubscriberId s) { out.push_back("r" + std::to_string(s.value())); },
                  [&](std::span<const std::byte> f) {
                    out.push_back("c" + std::to_string(std::to_integer<int>(f[0])));
                  })) {
  }
  return out;
}

TEST(FlowControl, Fresh_IsDrained_AndSomethingWaitingIsNot) {
  FlowControl flow;
  EXPECT_TRUE(flow.drained());
  const std::byte control[] = {std::byte{7}};
  ASSERT_EQ(flow.queue_control(control), FlowControl::Queued::Yes);
  EXPECT_FALSE(flow.drained()) << "a new frame would overtake the queued one";
  EXPECT_EQ(pop_all(flow), std::vector<std::string>{"c7"});
  EXPECT_TRUE(flow.drained());
  flow.request_sweep();
  EXPECT_FALSE(flow.drained()) << "a sweep to do";
  EXPECT_TRUE(flow.take_sweep());
  EXPECT_FALSE(flow.take_sweep()) << "taken once";
  EXPECT_TRUE(flow.drained());
}

TEST(FlowControl, RingAndControlEntries_PoppedInTheOrderQueued) {
  FlowControl flow;
  const std::byte a[] = {std::byte{1}};
  const std::byte b[] = {std::byte{2}};
  flow.queue_ring(SubscriberId{10});
  ASSERT_EQ(flow.queue_control(a), FlowControl::Queued::Yes);
  flow.queue_ring(SubscriberId{11});
  ASSERT_EQ(flow.queue_control(b), FlowControl::Queued::Yes);
  EXPECT_EQ(flow.queued(), 4U);
  EXPECT_EQ(pop_all(flow), (std::vector<std::string>{"r10", "c1", "r11", "c2"}));
  EXPECT_FALSE(flow.pop([](SubscriberId) {}, [](std::span<const std::byte>) {})) << "nothing waits";
}

TEST(FlowControl, ControlPool_FullAtItsCapacity_AndAPoppedFrameGivesItsEntryBack) {
  FlowControl flow;
  const std::byte f[] = {std::byte{3}};
  for (std::size_t i = 0; i < kControlPoolCapacity; ++i)
    ASSERT_EQ(flow.queue_control(f), FlowControl::Queued::Yes) << i;
  EXPECT_EQ(flow.queue_control(f), FlowControl::Queued::PoolFull);
  ASSERT_TRUE(flow.pop([](SubscriberId) {}, [](std::span<const std::byte>) {}));
  EXPECT_EQ(flow.queue_control(f), FlowControl::Queued::Yes) << "the popped frame's pool entry is free again";
}

TEST(FlowControl, FullOutQueue_RingEntriesTurnIntoASweep_ControlFramesStillFit) {
  FlowControl flow;
  const std::size_t ring_room = kOutQueueCapacity - kControlPoolCapacity;
  for (std::size_t i = 0; i < ring_room; ++i) flow.queue_ring(SubscriberId{i});
  EXPECT_FALSE(flow.sweeping());
  EXPECT_EQ(flow.queued(), ring_room);
  flow.queue_ring(SubscriberId{ring_room});
  EXPECT_TRUE(flow.sweeping()) << "the ring entry that found no room asks for a sweep instead";
  EXPECT_EQ(flow.queued(), ring_room) << "and is not queued";
  const std::byte f[] = {std::byte{4}};
  for (std::size_t i = 0; i < kControlPoolCapacity; ++i) {
    ASSERT_EQ(flow.queue_control(f), FlowControl::Queued::Yes)
        << "a Reply or a Shutdown always fits (" << i << ")";
  }
  EXPECT_EQ(flow.queued(), kOutQueueCapacity);
}

TEST(FlowControl, HeldFrame_WaitsFirstAndCountsWhenItLeaves) {
  FlowControl flow;
  const auto held = frame(5, 'h');
  flow.hold(held);
  EXPECT_FALSE(flow.drained());
  ASSERT_TRUE(flow.has_held());
  EXPECT_EQ(bytes_of(flow.held()), held);
  EXPECT_EQ(flow.frames_out(), 0U) << "refused by the channel: not sent yet";
  flow.held_sent();
  EXPECT_FALSE(flow.has_held());
  EXPECT_EQ(flow.frames_out(), 1U);
  EXPECT_TRUE(flow.drained());
}

TEST(FlowControl, FrameCount_ReportedAllOnlyWhenIdleCountsEveryFrameSinceTheChannelOpened) {
  FlowControl flow;
  flow.count_sent();
  flow.count_sent();
  flow.count_sent();
  EXPECT_FALSE(flow.reported_all());
  flow.on_idle(2);
  EXPECT_FALSE(flow.reported_all());
  flow.on_idle(3);
  EXPECT_TRUE(flow.reported_all());
  // A new channel (a restored image): its service counts from 0 again.
  flow.new_channel();
  EXPECT_TRUE(flow.reported_all());
  flow.count_sent();
  flow.count_sent();
  EXPECT_EQ(flow.frames_out(), 5U);
  EXPECT_FALSE(flow.reported_all());
  flow.uncount(1);  // refused by a full channel
  flow.on_idle(1);
  EXPECT_EQ(flow.reported(), 4U);
  EXPECT_TRUE(flow.reported_all());
}

TEST(FlowControl, Publications_BoundedPerStep_TheBoundRestartsEachStep) {
  FlowControl flow;
  for (std::size_t i = 0; i < kMaxStagedPerStep; ++i) ASSERT_TRUE(flow.admit_publication()) << i;
  EXPECT_FALSE(flow.admit_publication());
  flow.new_step();
  EXPECT_TRUE(flow.admit_publication());
}

TEST(FlowControl, Reset_DropsWhatWaitsButKeepsTheCount) {
  FlowControl flow;
  const std::byte f[] = {std::byte{5}};
  flow.count_sent();
  flow.queue_ring(SubscriberId{1});
  ASSERT_EQ(flow.queue_control(f), FlowControl::Queued::Yes);
  flow.hold(f);
  flow.request_sweep();
  flow.note_polled();
  EXPECT_TRUE(flow.set_want_writable(true));
  EXPECT_FALSE(flow.set_want_writable(true)) << "no change";
  flow.reset();
  EXPECT_TRUE(flow.drained());
  EXPECT_EQ(flow.queued(), 0U);
  EXPECT_FALSE(flow.take_polled());
  EXPECT_TRUE(flow.set_want_writable(true)) << "reset cleared the writable interest";
  EXPECT_EQ(flow.frames_out(), 1U);
  for (std::size_t i = 0; i < kControlPoolCapacity; ++i)
    ASSERT_EQ(flow.queue_control(f), FlowControl::Queued::Yes);
}

// ---- OutputBatch ----

TEST(OutputBatch, Add_CountsEachFrameAsSent_AndSaysFullAtTheCap) {
  OutputBatch batch;
  FlowControl flow;
  batch.open(2);
  EXPECT_TRUE(batch.is_open());
  const auto f = frame(3, 'a');
  for (std::size_t i = 1; i < kMaxCorkedFrames; ++i) ASSERT_FALSE(batch.add(ServiceId{1}, flow, f)) << i;
  EXPECT_TRUE(batch.add(ServiceId{1}, flow, f)) << "full: flush now";
  EXPECT_EQ(flow.frames_out(), kMaxCorkedFrames);
  EXPECT_TRUE(batch.has_frames(ServiceId{1}));
  EXPECT_FALSE(batch.has_frames(ServiceId{0}));
  batch.close();
  EXPECT_FALSE(batch.is_open());
}

TEST(OutputBatch, Flush_SendsTheFramesInOrderInOneDatagram_AndEmptiesTheBatch) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  ASSERT_TRUE(pair.has_value());
  OutputBatch batch;
  FlowControl flow;
  batch.open(1);
  const std::vector<std::vector<std::byte>> sent{frame(3, 'a'), frame(17, 'b'), frame(0, 'c')};
  for (const auto& f : sent) ASSERT_FALSE(batch.add(ServiceId{0}, flow, f));
  bool refused = false;
  batch.flush(ServiceId{0}, pair->first, flow, [&](std::span<const std::byte>) { refused = true; });
  EXPECT_FALSE(refused);
  EXPECT_FALSE(batch.has_frames(ServiceId{0}));
  EXPECT_EQ(flow.frames_out(), 3U);

  std::vector<std::byte> buf(wire::kMaxFrameBytes);
  auto got = pair->second.receive(buf);
  ASSERT_TRUE(got.has_value()) << got.error().to_string();
  const std::span<const std::byte> datagram(buf.data(), got->size);
  std::size_t offset = 0;
  for (const auto& want : sent) {
    ASSERT_LT(offset, datagram.size());
    EXPECT_EQ(bytes_of(wire::next_frame(datagram, offset)), want);
  }
  EXPECT_EQ(offset, datagram.size()) << "one datagram, nothing after the last frame";
}

TEST(OutputBatch, FullChannel_RefusedFramesUncountedAndHandedOverInOrder) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  ASSERT_TRUE(pair.has_value());
  const auto filler = frame(wire::kMaxLogText, 'x');
  for (int i = 0; i < 100000 && pair->first.send(filler).has_value(); ++i) {
  }
  OutputBatch batch;
  FlowControl flow;
  batch.open(1);
  const std::vector<std::vector<std::byte>> sent{frame(3, 'a'), frame(5, 'b')};
  for (const auto& f : sent) ASSERT_FALSE(batch.add(ServiceId{0}, flow, f));
  ASSERT_EQ(flow.frames_out(), 2U);
  std::vector<std::vector<std::byte>> refused;
  batch.flush(ServiceId{0}, pair->first, flow, [&](std::span<const std::byte> rest) {
    for (std::size_t offset = 0; offset < rest.size();)
      refused.push_back(bytes_of(wire::next_frame(rest, offset)));
  });
  EXPECT_EQ(refused, sent);
  EXPECT_EQ(flow.frames_out(), 0U) << "counted again when they really leave";
  EXPECT_FALSE(batch.has_frames(ServiceId{0}));
}

TEST(OutputBatch, NoChannel_NothingSentOrRefused_TheBatchEmptied) {
  OutputBatch batch;
  FlowControl flow;
  batch.open(1);
  ASSERT_FALSE(batch.add(ServiceId{0}, flow, frame(3, 'a')));
  bool refused = false;
  batch.flush(ServiceId{0}, sys::SeqPacket{}, flow, [&](std::span<const std::byte>) { refused = true; });
  EXPECT_FALSE(refused);
  EXPECT_FALSE(batch.has_frames(ServiceId{0}));
}

// ---- CanonicalStage ----

struct Drained {
  int key;
  char tag;
  std::string bytes;
  bool operator==(const Drained&) const = default;
};

std::span<const std::byte> text(const char* s) {
  return std::as_bytes(std::span(s, std::strlen(s)));
}

std::vector<Drained> drain(CanonicalStage<int, char>& stage) {
  std::vector<Drained> out;
  stage.drain([&](int key, char tag, std::span<const std::byte> b) {
    out.push_back(Drained{key, tag, std::string(reinterpret_cast<const char*>(b.data()), b.size())});
  });
  return out;
}

TEST(CanonicalStage, Drain_ByKeyThenArrival_WithEachEntrysBytes_ThenEmpty) {
  CanonicalStage<int, char> stage;
  stage.add(3, 'a', text("three"));
  stage.add(1, 'b', text("one"));
  stage.add(3, 'c', text("three again"));
  stage.add(2, 'd', text(""));
  EXPECT_EQ(stage.size(), 4U);
  EXPECT_EQ(drain(stage), (std::vector<Drained>{
                              {1, 'b', "one"}, {2, 'd', ""}, {3, 'a', "three"}, {3, 'c', "three again"}}));
  EXPECT_TRUE(stage.empty());
  EXPECT_TRUE(drain(stage).empty());
}

TEST(CanonicalStage, NextRound_StartsAfresh) {
  CanonicalStage<int, char> stage;
  stage.add(2, 'a', text("old"));
  (void)drain(stage);
  stage.add(5, 'b', text("new"));
  EXPECT_EQ(drain(stage), (std::vector<Drained>{{5, 'b', "new"}})) << "no bytes of the round drained before";
}

TEST(CanonicalStage, EraseIf_DropsTheMatchingEntriesOnly) {
  CanonicalStage<int, char> stage;
  stage.add(1, 'x', text("gone"));
  stage.add(2, 'y', text("kept"));
  stage.add(0, 'x', text("gone too"));
  stage.erase_if([](int, char tag) { return tag == 'x'; });
  EXPECT_EQ(stage.size(), 1U);
  EXPECT_EQ(drain(stage), (std::vector<Drained>{{2, 'y', "kept"}}));
}

// A stage that is only ever emptied by erase_if (a rollback every cycle dropping the cycle's only publications)
// holds no more bytes after a thousand cycles than after one.
TEST(CanonicalStage, EmptiedByEraseIfOnly_KeepsNoBytes) {
  CanonicalStage<int, char> stage;
  for (int cycle = 0; cycle < 1000; ++cycle) {
    stage.add(cycle, 'x', text("a publication of the rolled-back cycle"));
    stage.erase_if([](int, char tag) { return tag == 'x'; });
    ASSERT_TRUE(stage.empty());
    ASSERT_EQ(stage.bytes_held(), 0U) << "cycle " << cycle;
  }
  stage.add(1, 'y', text("kept"));
  stage.add(2, 'x', text("gone"));
  stage.erase_if([](int, char tag) { return tag == 'x'; });
  EXPECT_EQ(drain(stage), (std::vector<Drained>{{1, 'y', "kept"}}));
  EXPECT_EQ(stage.bytes_held(), 0U);
}

TEST(CanonicalStageDeathTest, AddWhileDraining_BreaksTheInvariant) {
  CanonicalStage<int, char> stage;
  stage.add(1, 'a', text("a"));
  EXPECT_DEATH(stage.drain([&](int, char, std::span<const std::byte>) { stage.add(2, 'b', text("b")); }),
               "nothing is staged while the stage is handed out");
}

// The kernel's own messages are published as their bytes, padding included: built over memory that held
// other bytes (0xAA here, a stack address in a run), a SecurityEvent and a RollbackSignal still publish zeros
// in their padding, so two runs with one seed publish the same bytes and no service reads the kernel's memory.
template <typename T>
std::vector<std::byte> built_over_dirty_memory(void (*set)(T&)) {
  alignas(KernelMessage<T>) std::byte storage[sizeof(KernelMessage<T>)];
  std::memset(storage, 0xAA, sizeof storage);
  auto* message = ::new (storage) KernelMessage<T>;  // default-initialised, as a kernel's local is
  set(message->fields);
  const auto bytes = std::as_bytes(std::span(&message->fields, 1));
  return {bytes.begin(), bytes.end()};
}

TEST(KernelMessage, PaddingIsZero_WhateverTheMemoryHeldBefore) {
  static_assert(sizeof(rejuv_msg_SecurityEvent) == 32 && offsetof(rejuv_msg_SecurityEvent, kind) == 24);
  const auto event = built_over_dirty_memory<rejuv_msg_SecurityEvent>([](rejuv_msg_SecurityEvent& e) {
    e.timestamp_ns = 1;
    e.service_id = 2;
    e.slot = 3;
    e.operation = 4;
    e.error = 5;
    e.mode = rejuv_msg_SR_MODE_MC;
    e.kind = rejuv_msg_SECURITY_CAPABILITY_DENIAL;
  });
  for (const std::size_t padding : {18U, 19U, 28U, 29U, 30U, 31U}) {
    EXPECT_EQ(event[padding], std::byte{0}) << "SecurityEvent byte " << padding;
  }
  // RollbackSignal has no padding since it carries the catch-up's state (epoch, catch_up, replayed_to_ns
  // packed): every byte is a field the kernel sets.
  static_assert(sizeof(rejuv_msg_RollbackSignal) == 32 && offsetof(rejuv_msg_RollbackSignal, epoch) == 16 &&
                offsetof(rejuv_msg_RollbackSignal, catch_up) == 20 &&
                offsetof(rejuv_msg_RollbackSignal, replayed_to_ns) == 24);
  const auto signal = built_over_dirty_memory<rejuv_msg_RollbackSignal>([](rejuv_msg_RollbackSignal& r) {
    r.timestamp_ns = 1;
    r.generation = 2;
    r.epoch = 3;
    r.catch_up = rejuv_msg_CATCH_UP_OFF;
    r.replayed_to_ns = 0;
  });
  for (const std::size_t at : {20U, 21U, 22U, 23U, 24U, 31U}) {
    EXPECT_EQ(signal[at], std::byte{0}) << "RollbackSignal byte " << at;
  }
}

}  // namespace
}  // namespace rejuv::kernel
