// One transport for both ends of a channel (docs/design.md §2; docs/protocol.md "Framing"): frames packed
// into datagrams on the way out, a burst of datagrams per system call on the way in. The kernel (router.cpp's
// corked rounds, channel_input.cpp's read_channel) and the SDK (services/sdk/src/transport.cpp) put frames on
// and take them off a channel with these and nothing else, so the packing rule of wire.hpp is written once.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "rejuv/channel/wire.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/fd.hpp"

namespace rejuv::channel {

// ---- sending ----

// Appends `frame` to `frames` as a datagram lays it out (wire::kFrameAlign): at the next aligned offset, the
// gap zero. `frames` may hold more than one datagram (a sender's queue); send_packed cuts it.
void append_frame(std::vector<std::byte>& frames, std::span<const std::byte> frame);
// The size `frames` would have after append_frame(frames, a frame of `frame_size` bytes).
[[nodiscard]] constexpr std::size_t size_after_append(std::size_t frames_size, std::size_t frame_size) {
  return wire::aligned_frame_size(frames_size) + frame_size;
}

// A send_packed that stopped: the send that failed, and how many bytes of the frames had left before it (a
// datagram boundary: what is left starts with a whole frame).
struct Unsent {
  sys::SysError error;
  std::size_t sent = 0;
};
// Sends `frames` (laid out by append_frame) in as few datagrams as hold them (wire::datagram_prefix), each
// without waiting (MSG_DONTWAIT); stops at the first send that fails (EAGAIN: the channel is full).
[[nodiscard]] Result<void, Unsent> send_packed(const sys::SeqPacket& channel, std::span<const std::byte> frames);

// ---- receiving ----

// Reads a channel a burst at a time: one recvmmsg (sys::SeqPacket::receive_batch) fills the caller's slots,
// one datagram per slot of wire::kMaxFrameBytes, and the reader hands them out — whole (next_datagram: the
// kernel, which checks each datagram before it walks its frames) or frame by frame (next_frame: the SDK).
// A burst smaller than the slots means the channel was empty after it: the next read that must not wait says
// so without a system call. Non-owning: the slots and receipts belong to the caller and outlive the reader.
class BatchReader {
 public:
  // One datagram of the burst: its bytes (a slot) and its receipt (truncated, fds, closed: the end).
  struct Datagram {
    std::span<const std::byte> bytes;
    sys::Received* receipt = nullptr;
  };
  // One frame of a datagram as wire::next_frame cuts it, not yet decoded; empty when the datagram was
  // truncated or is the end of the channel (receipt->closed). `first`: the datagram's first frame, which
  // takes its fds (receipt->fds).
  struct Frame {
    std::span<const std::byte> bytes;
    sys::Received* receipt = nullptr;
    bool first = false;
  };

  // `slots`: receipts.size() slots of wire::kMaxFrameBytes, 8-byte aligned (the wire layouts need it).
  BatchReader(std::span<std::byte> slots, std::span<sys::Received> receipts);

  // The next datagram; nullopt when none is waiting and `wait` is No. Wait::ForOne sleeps until one comes
  // (inside recvmmsg on a blocking channel, in poll on a non-blocking one). At most `max_fds` fds each.
  [[nodiscard]] sys::SysResult<std::optional<Datagram>> next_datagram(const sys::SeqPacket& channel,
                                                                      std::size_t max_fds, sys::Wait wait);
  // The next frame, of the datagram being walked or of the next one (as next_datagram).
  [[nodiscard]] sys::SysResult<std::optional<Frame>> next_frame(const sys::SeqPacket& channel, std::size_t max_fds,
                                                                sys::Wait wait);
  // Whether the next call hands out what is already read (no system call).
  [[nodiscard]] bool buffered() const { return walking_ || next_ < count_; }
  // Drops everything read ahead (a restored image: nothing sent to the old incarnation is read by the new).
  void forget();

 private:
  std::span<std::byte> slots_;
  std::span<sys::Received> receipts_;
  std::size_t next_ = 0;   // the next datagram of the burst to hand out
  std::size_t count_ = 0;  // datagrams in the burst
  bool drained_ = false;   // the last burst was smaller than the slots
  Datagram current_{};     // next_frame: the datagram being walked
  std::size_t offset_ = 0; // next_frame: where its next frame starts (wire::next_frame)
  bool walking_ = false;   // next_frame: current_ has frames left
};

}  // namespace rejuv::channel
