// Fuzz target: the SDK's handling of frames from the kernel (services/sdk/src: boot.cpp, transport.cpp, service.cpp): the boot script
// (Boot, BootCap × n, BootParam × m, BootEnd), Replies to its requests, and the run loop's Deliver,
// TimerFired, NetDatagram, Snapshot (without its fd: no image is taken) and Shutdown. The kernel is trusted,
// but a service must still never crash on what its channel holds.
//
// Input: records (u16 length, bytes), each one datagram the "kernel" has queued on the channel before the
// service reads it; then the kernel's end stops writing, so that the service reads end-of-file after them.
// The service connects, subscribes (push and polled), arms a timer, listens for datagrams, invokes a
// persistent cell, then runs until the channel ends — each step takes what the datagrams hold.
#include <sys/socket.h>

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>

#include "fuzz_input.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/clock/time_page.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/sdk/testing.hpp"
#include "rejuv/sys/channel.hpp"

namespace {

constexpr int kMaxDatagrams = 48;  // well inside a socket pair's buffer

struct World {
  std::optional<rejuv::clock::TimePageWriter> page;
  World() {
    auto p = rejuv::clock::TimePageWriter::create();
    if (p) {
      page.emplace(std::move(*p));
      page->write(rejuv::clock::TimeSample{.now = std::chrono::milliseconds{100}, .mode = rejuv::SrMode::MC,
                                           .epoch = rejuv::Epoch{0}});
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static World world;
  if (!world.page) return 0;
  auto pair = rejuv::sys::SeqPacket::pair(rejuv::sys::Blocking::No);
  if (!pair) return 0;
  rejuv::sys::SeqPacket& kernel = pair->first;
  rejuv::fuzz::Input in(data, size);
  for (int i = 0; i < kMaxDatagrams && !in.empty(); ++i) {
    if (!kernel.send(in.record())) break;  // the channel is full: the rest is not sent
  }
  ::shutdown(kernel.fd(), SHUT_WR);  // the service reads end-of-file after the queued datagrams
  const int service_fd = pair->second.take_fd().release();  // the Service owns it from here
  auto svc = rejuv::sdk::Service::connect(rejuv::sdk::ConnectOptions{
      .channel_fd = service_fd, .time_page_fd = world.page->read_only_fd().get()});
  if (!svc) {
    (void)svc.error().to_string();
    return 0;
  }
  rejuv::sdk::Service& s = **svc;
  (void)s.name();
  (void)s.param("gain", 0);
  (void)s.text_param("label", "");
  std::uint64_t seen = 0;
  auto push = s.subscribe<rejuv_msg_SensorBaro>("numbers", [&](const rejuv_msg_SensorBaro&) { ++seen; });
  auto polled = s.subscribe_polled<rejuv_msg_VehicleStateEstimate>("vehicle_state");
  auto timer = s.every(std::chrono::milliseconds{10}, [&] {
    if (polled) (void)polled->latest();
  });
  (void)s.on_datagram("ext_net", [&](std::span<const std::byte> d) { seen += d.size(); });
  std::array<std::byte, 64> out{};
  (void)rejuv::sdk::testing::invoke(s, "cell", rejuv::cap::Operation::PersistentRead, 0, 8, {}, out);
  (void)push;
  (void)timer;
  (void)s.run();
  return 0;
}
