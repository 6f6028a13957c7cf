#include "rejuv/channel/transport.hpp"

#include <cerrno>

#include "rejuv/sys/event.hpp"

namespace rejuv::channel {

void append_frame(std::vector<std::byte>& frames, std::span<const std::byte> frame) {
  frames.resize(wire::aligned_frame_size(frames.size()), std::byte{0});
  frames.insert(frames.end(), frame.begin(), frame.end());
}

Result<void, Unsent> send_packed(const sys::SeqPacket& channel, std::span<const std::byte> frames) {
  for (std::size_t start = 0; start < frames.size();) {
    const std::span<const std::byte> rest = frames.subspan(start);
    const std::size_t size = wire::datagram_prefix(rest);
    if (auto sent = channel.send(rest.first(size)); !sent) return fail(Unsent{.error = sent.error(), .sent = start});
    start += wire::aligned_frame_size(size);
  }
  return {};
}

BatchReader::BatchReader(std::span<std::byte> slots, std::span<sys::Received> receipts)
    : slots_(slots), receipts_(receipts.first(std::min(receipts.size(), slots.size() / wire::kMaxFrameBytes))) {}

sys::SysResult<std::optional<BatchReader::Datagram>> BatchReader::next_datagram(const sys::SeqPacket& channel,
                                                                              std::size_t max_fds, sys::Wait wait) {
  for (;;) {
    if (next_ < count_) {
      sys::Received& r = receipts_[next_];
      const std::span<const std::byte> bytes(slots_.data() + next_ * wire::kMaxFrameBytes, r.size);
      ++next_;
      return Datagram{.bytes = bytes, .receipt = &r};
    }
    if (drained_ && wait == sys::Wait::No) {
      drained_ = false;
      return std::optional<Datagram>{};
    }
    auto n = channel.receive_batch(slots_, wire::kMaxFrameBytes, receipts_, max_fds, wait);
    if (n) {
      next_ = 0;
      count_ = *n;
      drained_ = *n < receipts_.size() && !receipts_[*n - 1].closed;
      continue;
    }
    drained_ = false;
    if (n.error().error != EAGAIN) return std::unexpected(n.error());
    if (wait == sys::Wait::No) return std::optional<Datagram>{};
    // Only on a non-blocking channel (the wait is otherwise inside recvmmsg): wait, then read.
    if (auto w = sys::wait_fd(channel.fd(), sys::WaitFor::Readable, std::nullopt); !w) return std::unexpected(w.error());
  }
}

sys::SysResult<std::optional<BatchReader::Frame>> BatchReader::next_frame(const sys::SeqPacket& channel,
                                                                        std::size_t max_fds, sys::Wait wait) {
  if (!walking_) {
    auto datagram = next_datagram(channel, max_fds, wait);
    if (!datagram) return std::unexpected(datagram.error());
    if (!*datagram) return std::optional<Frame>{};
    current_ = **datagram;
    offset_ = 0;
    walking_ = true;
  }
  Frame frame{.bytes = {}, .receipt = current_.receipt, .first = offset_ == 0};
  if (current_.receipt->closed || current_.receipt->truncated) {
    walking_ = false;  // no frame in it: the caller sees the receipt (a truncated one decodes as TooShort)
    return frame;
  }
  frame.bytes = wire::next_frame(current_.bytes, offset_);
  if (offset_ >= current_.bytes.size()) walking_ = false;
  return frame;
}

void BatchReader::forget() {
  for (sys::Received& r : receipts_) r.fds.clear();
  next_ = count_ = offset_ = 0;
  drained_ = walking_ = false;
  current_ = {};
}

}  // namespace rejuv::channel
