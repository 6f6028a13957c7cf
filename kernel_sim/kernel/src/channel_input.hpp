// Channel input (requests.cpp): the frames each service sends on its channel, decoded and handled — the boot
// sequence, timers, logs, subscriptions and invocations (decoded per object kind, the authority checked, then
// invoked on the object's owner: invocation.hpp). Owns the receive buffer.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "invocation.hpp"
#include "rejuv/cap/cap_system.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/channel.hpp"
#include "service_runtime.hpp"
#include "vocabulary.hpp"

namespace rejuv::kernel {

class ChannelInput {
 public:
  explicit ChannelInput(Kernel::Impl& kernel) : k(kernel) {}

  void read_channel(ServiceRuntime& s);
  // The frames of one datagram read from the service's channel (no fd): handled one by one until one does
  // not decode (the rest of its datagram is refused with it) or the service is lost.
  void receive_datagram(ServiceRuntime& s, std::span<const std::byte> datagram);
  // Answers an Invoke with an error; a refused NetSend is counted by the gate (NetStats::send_refused).
  void refuse_invoke(ServiceRuntime& s, std::uint32_t seq, cap::Operation op, std::int32_t code);
  void reply(ServiceRuntime& s, std::uint32_t seq, std::int32_t error, std::uint64_t value = 0,
             std::span<const std::byte> data = {});

 private:
  void handle_frame(ServiceRuntime& s, const wire::FrameView& frame);
  void handle_hello(ServiceRuntime& s, const wire::FrameView& frame);  // Boot sent; Phase::Booted
  void handle_ready(ServiceRuntime& s);                                // Phase::Ready, the real-time plan
  void handle_timer_arm(ServiceRuntime& s, const wire::FrameView& frame);
  void handle_log(ServiceRuntime& s, const wire::FrameView& frame);
  void handle_subscribe(ServiceRuntime& s, const wire::FrameView& frame);
  // Invoke (invocation.hpp): decoded per object kind, the authority checked, then invoked on its owner.
  void handle_invoke(ServiceRuntime& s, const wire::FrameView& frame);
  [[nodiscard]] bool provides(ObjectKind kind) const;  // the Checkpoint kind only with SR
  void invoke_checkpoint(ServiceRuntime& s, std::uint32_t seq, const CheckpointInvocation& c);
  void invoke_limits(ServiceRuntime& s, std::uint32_t seq, ObjectInfo& o, const LimitsInvocation& l);
  void invoke_persistent(ServiceRuntime& s, std::uint32_t seq, ObjectInfo& o, const PersistentInvocation& p);

  Kernel::Impl& k;
  // read_channel: one frame slot per recvmmsg entry (8-byte aligned slots: the wire layouts need it).
  alignas(8) std::array<std::byte, wire::kMaxFrameBytes * sys::kMaxReceiveBatch> rx_batch{};
};

}  // namespace rejuv::kernel
