// The service SDK against a scripted kernel end (docs/protocol.md): boot, typed topics, uORB semantics,
// replies with queued frames, timers, Idle. The "kernel" here is the test: it writes frames into the
// channel before the SDK reads them and checks what the SDK sent.
#include <gtest/gtest.h>

#include <cerrno>
#include <deque>
#include <thread>
#include <vector>

#include "rejuv/channel/wire.hpp"
#include "rejuv/clock/time_page.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/sdk/testing.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/event.hpp"

namespace rejuv::sdk {
namespace {

using Record = rejuv_msg_SensorBaro;
using std::chrono::milliseconds;

struct Sent {
  wire::FrameKind kind{};
  wire::FrameHeader header{};
  std::vector<std::byte> payload;
};

// The kernel end of one service channel, scripted by the test.
class ScriptedKernel {
 public:
  ScriptedKernel() {
    auto pair = sys::SeqPacket::pair(sys::Blocking::Yes);
    EXPECT_TRUE(pair.has_value());
    kernel_ = std::move(pair->first);
    service_fd_ = pair->second.take_fd().release();
    auto page = clock::TimePageWriter::create();
    EXPECT_TRUE(page.has_value());
    page_.emplace(std::move(*page));
    page_->write(clock::TimeSample{.now = milliseconds{100}, .mode = SrMode::MC, .epoch = Epoch{0}});
  }

  void send(wire::FrameKind kind, std::uint32_t slot, std::uint32_t seq, std::uint64_t aux,
            std::span<const std::byte> payload = {}) {
    wire::FrameBuffer fb;
    ASSERT_TRUE(fb.build(kind, slot, seq, aux, payload));
    ASSERT_TRUE(kernel_.send(fb.bytes()).has_value());
  }
  template <class T>
  void send_body(wire::FrameKind kind, std::uint32_t slot, std::uint32_t seq, std::uint64_t aux, const T& body) {
    send(kind, slot, seq, aux, std::as_bytes(std::span(&body, 1)));
  }
  void reply(std::uint32_t seq, std::int32_t error, std::uint64_t value = 0, std::span<const std::byte> data = {}) {
    const wire::ReplyHeader h{.error = error, .reserved = 0, .value = value};
    wire::FrameBuffer fb;
    ASSERT_TRUE(fb.build_with(wire::FrameKind::Reply, 0, seq, 0, h, data));
    ASSERT_TRUE(kernel_.send(fb.bytes()).has_value());
  }
  template <class T>
  void deliver(std::uint32_t slot, std::uint64_t generation, const T& message) {
    send(wire::FrameKind::Deliver, slot, 0, generation, std::as_bytes(std::span(&message, 1)));
  }

  // The boot script: four caps and two params.
  void boot() {
    wire::BootHeader h{};
    h.service_id = 3;
    h.cap_count = 4;
    h.param_count = 2;
    (void)wire::copy_name(h.name, "probe");
    send_body(wire::FrameKind::Boot, 0, 0, wire::kProtocolVersion, h);
    const auto cap = [&](std::uint32_t slot, ObjectKind kind, std::string_view object, std::string_view type,
                         std::uint32_t size, std::array<std::uint8_t, 5> rights) {
      wire::BootCap c{};
      c.slot = slot;
      c.kind = static_cast<std::uint8_t>(kind);
      for (std::size_t m = 0; m < 5; ++m) c.rights_by_mode[m] = rights[m];
      c.payload_size = size;
      (void)wire::copy_name(c.object, object);
      (void)wire::copy_name(c.type, type);
      send_body(wire::FrameKind::BootCap, 0, 0, 0, c);
    };
    const std::uint8_t r = 1, w = 2;
    cap(1, ObjectKind::Topic, "numbers", "rejuv::msg::SensorBaro", sizeof(Record), {r, r, r, r, r});
    cap(2, ObjectKind::Topic, "out", "rejuv::msg::SensorBaro", sizeof(Record), {w, 0, 0, 0, 0});
    cap(3, ObjectKind::Persistent, "cell", "", 8, {r | w, r | w, r | w, r | w, r | w});
    cap(4, ObjectKind::Topic, "vehicle_state", "rejuv::msg::VehicleStateEstimate",
        sizeof(rejuv_msg_VehicleStateEstimate), {r, r, r, r, r});
    wire::BootParam p{};
    (void)wire::copy_name(p.name, "gain");
    p.number = 2.5;
    send_body(wire::FrameKind::BootParam, 0, 0, 0, p);
    wire::BootParam t{};
    (void)wire::copy_name(t.name, "label");
    (void)wire::copy_name(t.text, "x");
    t.is_text = 1;
    send_body(wire::FrameKind::BootParam, 0, 0, 0, t);
    send(wire::FrameKind::BootEnd, 0, 0, 0);
  }

  std::unique_ptr<Service> connect() {
    auto svc = Service::connect(ConnectOptions{.channel_fd = service_fd_,
                                               .time_page_fd = page_->read_only_fd().get()});
    EXPECT_TRUE(svc.has_value()) << svc.error().to_string();
    return svc ? std::move(*svc) : nullptr;
  }

  // Every frame the SDK has sent so far.
  std::vector<Sent> sent() {
    std::vector<Sent> out(pending_.begin(), pending_.end());
    pending_.clear();
    while (sys::wait_fd(kernel_.fd(), sys::WaitFor::Readable, Nanos{0}).value_or(false) && receive_datagram()) {
      out.insert(out.end(), pending_.begin(), pending_.end());
      pending_.clear();
    }
    return out;
  }
  // Blocks for the next frame the SDK sends.
  Sent next() {
    if (pending_.empty()) {
      EXPECT_TRUE(receive_datagram());
    }
    if (pending_.empty()) return Sent{};
    Sent f = std::move(pending_.front());
    pending_.pop_front();
    return f;
  }

  clock::TimePageWriter& page() { return *page_; }
  [[nodiscard]] int service_fd() const { return service_fd_; }
  // Reads one datagram and queues each frame of it (the SDK packs what it sends: wire::next_frame).
  bool receive_datagram() {
    std::array<std::byte, wire::kMaxFrameBytes> buf{};
    auto r = kernel_.receive(buf);
    if (!r || r->closed) return false;
    const std::span<const std::byte> datagram(buf.data(), r->size);
    std::size_t offset = 0;
    do {
      auto f = wire::decode(wire::next_frame(datagram, offset), wire::Direction::ToKernel);
      EXPECT_TRUE(f.has_value());
      if (!f) return true;
      pending_.push_back(Sent{f->kind, f->header, std::vector<std::byte>(f->payload.begin(), f->payload.end())});
    } while (offset < datagram.size());
    return true;
  }
  void close() { kernel_.close(); }

 private:
  sys::SeqPacket kernel_;
  std::deque<Sent> pending_;  // frames of a datagram read, not yet handed out
  int service_fd_ = -1;
  std::optional<clock::TimePageWriter> page_;
};

class SdkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    kernel.boot();
    svc = kernel.connect();
    ASSERT_NE(svc, nullptr);
    const auto hello = kernel.sent();
    ASSERT_EQ(hello.size(), 1U);
    EXPECT_EQ(hello[0].kind, wire::FrameKind::Hello);
    EXPECT_EQ(hello[0].header.aux, wire::kProtocolVersion);
  }
  ScriptedKernel kernel;
  std::unique_ptr<Service> svc;
};

TEST_F(SdkTest, Connect_ReadsIdentityCapsAndParams) {
  EXPECT_EQ(svc->id(), ServiceId{3});
  EXPECT_EQ(svc->caps().size(), 4U);
  auto numbers = svc->cap("numbers");
  ASSERT_TRUE(numbers.has_value());
  EXPECT_EQ((*numbers)->slot, Slot{1});
  EXPECT_TRUE((*numbers)->rights_in(SrMode::SC).has(Right::Read));
  EXPECT_EQ((*numbers)->payload_size, sizeof(Record));
  EXPECT_DOUBLE_EQ(svc->param("gain", 0), 2.5);
  EXPECT_DOUBLE_EQ(svc->param("missing", 7), 7);
  EXPECT_EQ(svc->text_param("label", ""), "x");
  EXPECT_TRUE(svc->has_param("label"));
  EXPECT_EQ(svc->now(), milliseconds{100});
  EXPECT_EQ(svc->mode(), SrMode::MC);
}

TEST_F(SdkTest, Advertise_ChecksNameKindTypeAndRights) {
  EXPECT_TRUE(svc->advertise<Record>("out").has_value());
  const auto nope = svc->advertise<Record>("nope");
  ASSERT_FALSE(nope.has_value());
  EXPECT_EQ(nope.error().code, SdkError::NoSuchObject);
  // The message names the grant to add and what the service holds.
  EXPECT_NE(nope.error().detail.find("grants { service: \"" + std::string(svc->name()) + "\" object: \"nope\""),
            std::string::npos) << nope.error().detail;
  EXPECT_NE(nope.error().detail.find("it holds: "), std::string::npos) << nope.error().detail;
  EXPECT_EQ(svc->advertise<Record>("cell").error().code, SdkError::WrongObjectKind);
  EXPECT_EQ(svc->advertise<rejuv_msg_ActuatorControls>("out").error().code, SdkError::TypeMismatch);
  EXPECT_EQ(svc->advertise<Record>("numbers").error().code, SdkError::NeverGranted);
}

TEST_F(SdkTest, Publish_SendsOnlyWhenWriteIsHeldInTheCurrentMode) {
  auto out = svc->advertise<Record>("out");
  ASSERT_TRUE(out.has_value());
  Record r{};
  r.pressure_pa = 42;
  ASSERT_TRUE(out->publish(r).has_value());
  kernel.page().write(clock::TimeSample{.now = milliseconds{100}, .mode = SrMode::SC, .epoch = Epoch{0}});
  auto refused = out->publish(r);
  ASSERT_FALSE(refused.has_value());
  EXPECT_EQ(refused.error().code, SdkError::NotHeldInMode);
  ASSERT_TRUE(rejuv::sdk::testing::publish_unchecked(*out, r).has_value());
  EXPECT_TRUE(kernel.sent().empty()) << "queued until the service waits or flushes";
  ASSERT_TRUE(svc->flush().has_value());
  const auto sent = kernel.sent();
  ASSERT_EQ(sent.size(), 2U);
  for (const Sent& s : sent) {
    EXPECT_EQ(s.kind, wire::FrameKind::Publish);
    EXPECT_EQ(s.header.slot, 2U);
    ASSERT_EQ(s.payload.size(), sizeof(Record));
  }
}

TEST_F(SdkTest, Subscribe_DeliversInOrderWithUorbSemanticsAndCountsGaps) {
  kernel.reply(1, 0);
  std::vector<double> seen;
  auto sub = svc->subscribe<Record>("numbers", [&](const Record& r) { seen.push_back(r.pressure_pa); });
  ASSERT_TRUE(sub.has_value()) << sub.error().to_string();
  const auto request = kernel.sent();
  ASSERT_EQ(request.size(), 1U);
  EXPECT_EQ(request[0].kind, wire::FrameKind::Subscribe);
  EXPECT_EQ(request[0].header.slot, 1U);
  EXPECT_EQ(request[0].header.aux, 0U);  // deliveries wake the service (not kSubscribePolled)
  EXPECT_FALSE(sub->updated());
  for (const auto& [g, v] : std::vector<std::pair<std::uint64_t, double>>{{5, 1}, {6, 2}, {9, 3}}) {
    Record r{};
    r.pressure_pa = v;
    kernel.deliver(1, g, r);
  }
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  EXPECT_EQ(svc->run(), 0);
  EXPECT_EQ(seen, (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(sub->generation(), 9U);
  EXPECT_EQ(sub->lost(), 2U);  // generations 7 and 8 never arrived
  EXPECT_TRUE(sub->updated());
  EXPECT_DOUBLE_EQ(sub->copy().pressure_pa, 3);
  EXPECT_FALSE(sub->updated());
}

TEST_F(SdkTest, SubscribePolled_AsksForAPolledSubscriptionAndReadsLikeAnyOther) {
  kernel.reply(1, 0);
  auto sub = svc->subscribe_polled<Record>("numbers");
  ASSERT_TRUE(sub.has_value()) << sub.error().to_string();
  const auto request = kernel.sent();
  ASSERT_EQ(request.size(), 1U);
  EXPECT_EQ(request[0].kind, wire::FrameKind::Subscribe);
  EXPECT_EQ(request[0].header.slot, 1U);
  EXPECT_EQ(request[0].header.aux, wire::kSubscribePolled);
  // Handed over by the kernel (before a frame that wakes the service), a delivery reads like any other.
  Record r{};
  r.pressure_pa = 7;
  kernel.deliver(1, 3, r);
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  EXPECT_EQ(svc->run(), 0);
  ASSERT_TRUE(sub->updated());
  EXPECT_DOUBLE_EQ(sub->copy().pressure_pa, 7);
  EXPECT_EQ(sub->generation(), 3U);
}

TEST_F(SdkTest, SubscribeDenied_ReturnsTheCapError) {
  kernel.reply(1, 1 + static_cast<std::int32_t>(cap::CapError::InsufficientRights));
  auto sub = svc->subscribe<Record>("numbers");
  ASSERT_FALSE(sub.has_value());
  EXPECT_EQ(sub.error().code, SdkError::Denied);
  EXPECT_EQ(sub.error().cap_error, cap::CapError::InsufficientRights);
}

TEST_F(SdkTest, FramesArrivingBeforeAReply_AreHandledAfterItInOrder) {
  kernel.reply(1, 0);
  std::vector<double> seen;
  auto sub = svc->subscribe<Record>("numbers", [&](const Record& r) { seen.push_back(r.pressure_pa); });
  ASSERT_TRUE(sub.has_value());
  Record r{};
  r.pressure_pa = 11;
  kernel.deliver(1, 0, r);
  const std::array<std::byte, 3> data{std::byte{1}, std::byte{2}, std::byte{3}};
  kernel.reply(2, 0, 42, data);
  std::array<std::byte, 8> out{};
  auto got = rejuv::sdk::testing::invoke(*svc, "cell", cap::Operation::PersistentRead, 0, 3, {}, out);
  ASSERT_TRUE(got.has_value()) << got.error().to_string();
  EXPECT_EQ(got->value, 42U);
  EXPECT_EQ(got->data_size, 3U);
  EXPECT_EQ(out[2], std::byte{3});
  EXPECT_TRUE(seen.empty()) << "the delivery waits until the reply is handled";
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  EXPECT_EQ(svc->run(), 0);
  EXPECT_EQ(seen, std::vector<double>{11});
}

TEST_F(SdkTest, InvokeFailure_IsAnOperationError) {
  kernel.reply(1, static_cast<std::int32_t>(wire::OpError::NotSupported));
  auto got = rejuv::sdk::testing::invoke(*svc, "cell", cap::Operation::PersistentWrite);
  ASSERT_FALSE(got.has_value());
  EXPECT_EQ(got.error().code, SdkError::OperationFailed);
  EXPECT_EQ(got.error().wire_error, static_cast<std::int32_t>(wire::OpError::NotSupported));
}

TEST_F(SdkTest, Timers_ArmFireAndCancel) {
  int periodic = 0;
  int once = 0;
  auto every = svc->every(milliseconds{4}, [&] { ++periodic; });
  ASSERT_TRUE(every.has_value());
  auto after = svc->after(milliseconds{10}, [&] { ++once; });
  ASSERT_TRUE(after.has_value());
  ASSERT_TRUE(svc->flush().has_value());
  const auto arms = kernel.sent();
  ASSERT_EQ(arms.size(), 2U);
  wire::TimerSpec spec{};
  std::memcpy(&spec, arms[0].payload.data(), sizeof(spec));
  EXPECT_EQ(spec.first_ns, 104'000'000U);  // now (100 ms) + one period
  EXPECT_EQ(spec.period_ns, 4'000'000U);
  kernel.send(wire::FrameKind::TimerFired, 0, 0, every->id());
  kernel.send(wire::FrameKind::TimerFired, 0, 0, after->id());
  kernel.send(wire::FrameKind::TimerFired, 0, 0, after->id());  // a one-shot fires once
  kernel.send(wire::FrameKind::TimerFired, 0, 0, every->id());
  kernel.send(wire::FrameKind::TimerFired, 0, 0, 12345);         // nobody's
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  EXPECT_EQ(svc->run(), 0);
  EXPECT_EQ(periodic, 2);
  EXPECT_EQ(once, 1);
  ASSERT_TRUE(every->cancel().has_value());
  EXPECT_EQ(every->cancel().error().code, SdkError::NoSuchTimer);
  EXPECT_EQ(svc->every(Nanos{10}, [] {}).error().code, SdkError::BadArgument);
}

// Firings of one timer that arrive while a request waits fire it once (as the kernel coalesces missed periods):
// a service that restores and checkpoints again before handling them must not carry one more in each image.
TEST_F(SdkTest, FiringsOfOneTimerQueuedDuringARequest_FireItOnce) {
  int periodic = 0;
  int other = 0;
  auto every = svc->every(milliseconds{4}, [&] { ++periodic; });
  auto second = svc->every(milliseconds{8}, [&] { ++other; });
  ASSERT_TRUE(every.has_value() && second.has_value());
  ASSERT_TRUE(svc->flush().has_value());
  (void)kernel.sent();
  for (int i = 0; i < 50; ++i) kernel.send(wire::FrameKind::TimerFired, 0, 0, every->id());
  kernel.send(wire::FrameKind::TimerFired, 0, 0, second->id());
  kernel.reply(1, 0);
  auto got = rejuv::sdk::testing::invoke(*svc, "cell", cap::Operation::PersistentWrite);
  ASSERT_TRUE(got.has_value()) << got.error().to_string();
  EXPECT_EQ(periodic, 0) << "nothing fires inside the request";
  kernel.send(wire::FrameKind::TimerFired, 0, 0, every->id());  // a firing after the request: its own
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  EXPECT_EQ(svc->run(), 0);
  EXPECT_EQ(periodic, 2);
  EXPECT_EQ(other, 1);
}

TEST_F(SdkTest, Run_SendsReadyThenIdleWithTheCountOfFramesReceived) {
  auto sub = [&] {
    kernel.reply(1, 0);
    return svc->subscribe<Record>("numbers");
  }();
  ASSERT_TRUE(sub.has_value());
  (void)kernel.sent();
  // Boot (8 frames) + the Reply = 9 frames received so far.
  std::thread loop([&] { EXPECT_EQ(svc->run(), 0); });
  EXPECT_EQ(kernel.next().kind, wire::FrameKind::Ready);
  const Sent idle = kernel.next();
  EXPECT_EQ(idle.kind, wire::FrameKind::Idle);
  EXPECT_EQ(idle.header.aux, 9U);
  kernel.deliver(1, 0, Record{});
  const Sent idle2 = kernel.next();
  EXPECT_EQ(idle2.kind, wire::FrameKind::Idle);
  EXPECT_EQ(idle2.header.aux, 10U);
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  loop.join();
  EXPECT_EQ(sub->received(), 1U);
}

TEST_F(SdkTest, MalformedFramesFromTheKernel_AreIgnored) {
  const std::array<std::byte, 7> junk{};
  kernel.send(wire::FrameKind::Deliver, 77, 0, 0, junk);  // no subscription on slot 77
  kernel.send(wire::FrameKind::Reply, 0, 99, 0, junk);     // a reply nobody waits for
  kernel.send(wire::FrameKind::Shutdown, 0, 0, 0);
  EXPECT_EQ(svc->run(), 0);
}

TEST_F(SdkTest, KernelGone_EndsRunWithOne) {
  kernel.close();
  EXPECT_EQ(svc->run(), 1);
}

// Found by tests/fuzz sdk_frames (regressions/sdk_frames/boot_cap_huge_slot): a slot sized a table.
TEST(SdkConnect, BootCapSlotOutsideTheCSpace_IsAProtocolError) {
  ScriptedKernel kernel;
  wire::BootHeader h{};
  h.cap_count = 1;
  kernel.send_body(wire::FrameKind::Boot, 0, 0, wire::kProtocolVersion, h);
  wire::BootCap c{};
  c.slot = 0xF900'0001U;
  kernel.send_body(wire::FrameKind::BootCap, 0, 0, 0, c);
  kernel.send(wire::FrameKind::BootEnd, 0, 0, 0);
  auto svc = Service::connect(ConnectOptions{.channel_fd = kernel.service_fd(),
                                             .time_page_fd = kernel.page().read_only_fd().get()});
  ASSERT_FALSE(svc.has_value());
  EXPECT_EQ(svc.error().code, SdkError::Protocol);
}

TEST(SdkConnect, WithoutTheKernelsFds_IsNotAService) {
  auto svc = Service::connect(ConnectOptions{.channel_fd = 900, .time_page_fd = 901});
  ASSERT_FALSE(svc.has_value());
  EXPECT_EQ(svc.error().code, SdkError::NotAService);
}

}  // namespace
}  // namespace rejuv::sdk
