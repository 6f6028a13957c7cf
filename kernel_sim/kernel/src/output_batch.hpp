// Output batching within a lockstep routing round (the router's cork, router.cpp; docs/performance.md): owned
// by the router, used only between cork() and uncork() (begin_step, advance_step), around routing that sends
// nothing else on the channels.
//
// While the batch is open, a frame that would go out at once (its service has nothing waiting: FlowControl::
// drained) is added to the service's batch instead, laid out as in a datagram; the flush sends it in as few
// datagrams as hold it (wire::datagram_prefix), so the deliveries of a round wake a service once, not once per
// frame (the service would otherwise wake on the first, report Idle, and wake again). A batch is capped at
// kMaxCorkedFrames, so what a full channel refuses fits in the service's control pool.
//
// The frame count (docs/protocol.md "Idle") is kept here for batched frames: a frame is counted when it is
// added (the service is not idle until it has reported it too), and what the channel refuses (EAGAIN) is
// un-counted at the flush, to be counted again when it really leaves.
#pragma once

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "rejuv/channel/transport.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/sys/channel.hpp"
#include "service_runtime.hpp"

namespace rejuv::kernel {

inline constexpr std::size_t kMaxCorkedFrames = 64;  // frames per service per batch

class OutputBatch {
 public:
  // Opens a batch for each of `services` services (empty; a flush left them so).
  void open(std::size_t services) {
    if (batches_.size() != services) batches_.resize(services);
    open_ = true;
  }
  // Closes it: from now on frames go out at once. The caller flushes every service that has_frames.
  void close() { open_ = false; }
  [[nodiscard]] bool is_open() const { return open_; }
  [[nodiscard]] bool has_frames(ServiceId service) const { return batches_[service.value()].count > 0; }

  // Adds `frame` to the service's batch, counted as sent (flow). True when the batch is full: flush it now.
  [[nodiscard]] bool add(ServiceId service, FlowControl& flow, std::span<const std::byte> frame) {
    Batch& b = batches_[service.value()];
    channel::append_frame(b.frames, frame);
    flow.count_sent();
    return ++b.count == kMaxCorkedFrames;
  }

  // Sends the service's batch on `channel` (none: nothing is sent) and empties it. When the channel is full
  // (EAGAIN) the frames it refused are un-counted and handed, in order and laid out as in a datagram, to
  // `refused(frames)`, which holds the first and queues the rest (the service's out-queue was empty, or the
  // frames would not be in the batch). EPIPE: the service is gone (its pidfd will say so); nothing more.
  template <class Refused>
  void flush(ServiceId service, const sys::SeqPacket& channel, FlowControl& flow, Refused&& refused) {
    Batch& b = batches_[service.value()];
    auto sent = channel.valid() ? channel::send_packed(channel, b.frames) : Result<void, channel::Unsent>{};
    if (!sent && sent.error().error.error == EAGAIN) {
      const std::span<const std::byte> rest = std::span<const std::byte>(b.frames).subspan(sent.error().sent);
      std::uint64_t frames = 0;
      std::size_t offset = 0;
      do {
        (void)wire::next_frame(rest, offset);
        ++frames;
      } while (offset < rest.size());
      flow.uncount(frames);
      refused(rest);
    }
    b.frames.clear();
    b.count = 0;
  }

 private:
  struct Batch {
    std::vector<std::byte> frames;  // back to back, aligned (wire::next_frame)
    std::size_t count = 0;
  };
  bool open_ = false;
  std::vector<Batch> batches_;  // by service
};

}  // namespace rejuv::kernel
