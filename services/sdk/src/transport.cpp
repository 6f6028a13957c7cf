// The SDK's side of the channel transport (docs/protocol.md "Framing"): frames queued and sent packed
// (channel::append_frame, channel::send_packed), bursts read and handed out frame by frame
// (channel::BatchReader), and a request that waits for its Reply. The packing and batching rules are the
// channel's (rejuv/channel/transport.hpp), shared with the kernel.
#include <algorithm>
#include <cerrno>
#include <cstring>

#include "rejuv/channel/codes.hpp"
#include "rejuv/sys/event.hpp"
#include "service_impl.hpp"

namespace rejuv::sdk {

SdkResult<void> Service::Impl::queue(std::span<const std::byte> frame) {
  if (channel::size_after_append(out.size(), frame.size()) > kOutBytes) {
    if (auto f = flush(); !f) return f;
  }
  channel::append_frame(out, frame);
  return {};
}

SdkResult<void> Service::Impl::flush() {
  std::size_t start = 0;
  for (;;) {
    auto sent = channel::send_packed(channel, std::span<const std::byte>(out).subspan(start));
    if (sent) break;
    start += sent.error().sent;
    const int e = sent.error().error.error;
    if (e == EPIPE || e == ECONNRESET) {
      out.clear();
      return error(SdkError::ChannelClosed);
    }
    if (e != EAGAIN) {
      out.clear();
      return io_error(sent.error().error);
    }
    if (auto w = sys::wait_fd(channel.fd(), sys::WaitFor::Writable, std::nullopt); !w) return io_error(w.error());
  }
  out.clear();
  return {};
}

SdkResult<std::optional<std::size_t>> Service::Impl::receive(bool wait) {
  auto got = reader.next_frame(channel, 2, wait ? sys::Wait::ForOne : sys::Wait::No);
  if (!got) return io_error(got.error());
  if (!*got) return std::optional<std::size_t>{};
  const channel::BatchReader::Frame& frame = **got;
  if (frame.receipt->closed) return error(SdkError::ChannelClosed);
  ++frames_received;
  if (frame.first) {
    rx_fds = std::move(frame.receipt->fds);
  } else {
    rx_fds.clear();
  }
  // A truncated datagram hands out an empty frame: it decodes as TooShort and is counted as bad.
  if (!frame.bytes.empty()) std::memcpy(rx.data(), frame.bytes.data(), frame.bytes.size());
  return std::optional<std::size_t>(frame.bytes.size());
}

SdkResult<InvokeReply> Service::Impl::request(std::span<std::byte> reply_data, std::string_view what) {
  const std::uint32_t want = seq;
  if (auto s = send(tx.bytes()); !s) return std::unexpected(s.error());
  for (;;) {
    auto got = receive(true);
    if (!got) return std::unexpected(got.error());
    const std::span<const std::byte> bytes(rx.data(), **got);
    auto frame = wire::decode(bytes, wire::Direction::ToService);
    if (frame && frame->kind == wire::FrameKind::Snapshot) {
      // A checkpoint while this process waits (the caller of checkpoint() always does): the image is
      // taken inside the call and, once restored, returns from it with RolledBack (docs/design.md §7).
      auto resumed = take_image(frame->header.aux, wire::payload_as<wire::SnapshotBody>(*frame).base);
      if (!resumed) return std::unexpected(resumed.error());
      if (*resumed) return error(SdkError::RolledBack, std::string(what));
      continue;
    }
    if (frame && frame->kind == wire::FrameKind::Reply && frame->header.seq == want) {
      const auto head = wire::payload_as<wire::ReplyHeader>(*frame);
      if (head.error != channel::kReplyOk) return reply_error(head.error, std::string(what));
      const auto data = frame->payload.subspan(sizeof(wire::ReplyHeader));
      const std::size_t n = std::min(data.size(), reply_data.size());
      if (n > 0) std::memcpy(reply_data.data(), data.data(), n);  // reply_data may be empty (a null data())
      return InvokeReply{.value = head.value, .data_size = n};
    }
    if (frame && frame->kind == wire::FrameKind::TimerFired && fire_queued(frame->header.aux)) continue;
    queued.emplace_back(bytes.begin(), bytes.end());
  }
}

// A timer that fires again while its last firing still waits in `queued` fires once: the kernel coalesces the
// periods a timer missed the same way (clock/timers.cpp collect_due). Without this a service that checkpoints
// right after a restore, before it has handled what it read meanwhile, carries one more firing in each image,
// and its last incarnation handles them all at one instant.
bool Service::Impl::fire_queued(std::uint64_t timer_id) const {
  return std::any_of(queued.begin(), queued.end(), [&](const std::vector<std::byte>& q) {
    auto f = wire::decode(q, wire::Direction::ToService);
    return f && f->kind == wire::FrameKind::TimerFired && f->header.aux == timer_id;
  });
}

}  // namespace rejuv::sdk
