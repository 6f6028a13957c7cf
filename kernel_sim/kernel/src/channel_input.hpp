// ChannelInput (channel_input.cpp): the frames each service sends on its channel, decoded and handled — the
// boot sequence, timers, logs, subscriptions and invocations (decoded per object kind, the authority checked,
// then invoked on the object's owner: invocation.hpp). Owns the receive buffer and the pauses of the channels
// of services over their publication budget.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
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
  // Real time: the channel of a service over its publication budget is not read for kBudgetPause of wall time
  // after a wakeup (docs/sandbox.md "Floods cost only the flooder"): its channel fills and its sends wait, so
  // a flood costs the flooder's time, not the kernel's. resume_paused reads them again once their pause is over;
  // next_resume is the earliest (the event loop's timeout).
  static constexpr std::chrono::milliseconds kBudgetPause{10};
  void resume_paused(Nanos wall_now);
  [[nodiscard]] std::optional<Nanos> next_resume() const;
  [[nodiscard]] bool paused(const ServiceRuntime& s) const {
    return s.id.value() < paused_until.size() && paused_until[s.id.value()].has_value();
  }
  // The frames of one datagram read from the service's channel (no fd): handled one by one until one does
  // not decode (the rest of its datagram is refused with it) or the service is lost.
  void receive_datagram(ServiceRuntime& s, std::span<const std::byte> datagram);
  // Answers an Invoke with an error; a refused NetSend is counted by the gate (NetStats::send_refused).
  void refuse_invoke(ServiceRuntime& s, std::uint32_t seq, cap::Operation op, std::int32_t code);
  void reply(ServiceRuntime& s, std::uint32_t seq, std::int32_t error, std::uint64_t value = 0,
             std::span<const std::byte> data = {});

 private:
  void read_frames(ServiceRuntime& s);  // up to kFramesPerWakeup frames (and what a datagram holds past them)
  void pause(ServiceRuntime& s);
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
  std::vector<std::optional<Nanos>> paused_until;  // wall time, by ServiceId value
};

}  // namespace rejuv::kernel
