// The channel transport over a real socket pair: frames packed by append_frame and sent by send_packed
// arrive, through a BatchReader, as the frames that went in, in order, laid out as docs/protocol.md
// "Framing" says (byte for byte); a full channel stops send_packed at a datagram boundary.
#include <gtest/gtest.h>

#include <sys/socket.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <vector>

#include "rejuv/channel/transport.hpp"

namespace rejuv::channel {
namespace {

std::vector<std::byte> log_frame(std::size_t text_bytes, char fill) {
  wire::FrameBuffer f;
  const std::vector<char> text(text_bytes, fill);
  EXPECT_TRUE(f.build_with(wire::FrameKind::Log, 0, 0, 0, wire::LogHeader{}, std::as_bytes(std::span(text))));
  return {f.bytes().begin(), f.bytes().end()};
}

struct Reader {
  alignas(8) std::array<std::byte, wire::kMaxFrameBytes * 4> slots{};
  std::array<sys::Received, 4> receipts{};
  BatchReader reader{slots, receipts};
};

TEST(Transport, AppendFrame_AlignsWithZeroGap) {
  std::vector<std::byte> frames;
  const auto a = log_frame(3, 'a');  // 24 + 8 + 3 = 35 bytes: padded to 40
  const auto b = log_frame(0, 'b');
  append_frame(frames, a);
  append_frame(frames, b);
  ASSERT_EQ(frames.size(), wire::aligned_frame_size(a.size()) + b.size());
  EXPECT_EQ(std::memcmp(frames.data(), a.data(), a.size()), 0);
  for (std::size_t i = a.size(); i < wire::aligned_frame_size(a.size()); ++i) EXPECT_EQ(frames[i], std::byte{0});
  EXPECT_EQ(std::memcmp(frames.data() + wire::aligned_frame_size(a.size()), b.data(), b.size()), 0);
  EXPECT_EQ(size_after_append(a.size(), b.size()), frames.size());
}

TEST(Transport, SendPackedThenNextFrame_SameFramesInOneDatagram) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  ASSERT_TRUE(pair.has_value());
  std::vector<std::vector<std::byte>> sent{log_frame(3, 'a'), log_frame(17, 'b'), log_frame(0, 'c')};
  std::vector<std::byte> frames;
  for (const auto& f : sent) append_frame(frames, f);
  ASSERT_TRUE(send_packed(pair->first, frames).has_value());

  Reader r;
  auto datagram = r.reader.next_datagram(pair->second, 0, sys::Wait::No);
  ASSERT_TRUE(datagram.has_value() && datagram->has_value());
  // One datagram: the frames as laid out, without the padding after the last.
  ASSERT_EQ((*datagram)->bytes.size(), frames.size());
  EXPECT_EQ(std::memcmp((*datagram)->bytes.data(), frames.data(), frames.size()), 0);
  EXPECT_FALSE(r.reader.buffered());

  ASSERT_TRUE(send_packed(pair->first, frames).has_value());
  Reader again;
  for (const auto& want : sent) {
    auto got = again.reader.next_frame(pair->second, 0, sys::Wait::No);
    ASSERT_TRUE(got.has_value() && got->has_value());
    ASSERT_EQ((*got)->bytes.size(), want.size());
    EXPECT_EQ(std::memcmp((*got)->bytes.data(), want.data(), want.size()), 0);
    EXPECT_EQ((*got)->first, &want == &sent.front());
  }
  auto none = again.reader.next_frame(pair->second, 0, sys::Wait::No);
  ASSERT_TRUE(none.has_value());
  EXPECT_FALSE(none->has_value());
}

TEST(Transport, MoreThanOneDatagram_SplitAtWholeFrames) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  ASSERT_TRUE(pair.has_value());
  std::vector<std::vector<std::byte>> sent;
  std::vector<std::byte> frames;
  for (int i = 0; i < 10; ++i) {  // 10 × 1056 bytes: two datagrams of at most kMaxFrameBytes
    sent.push_back(log_frame(wire::kMaxLogText, static_cast<char>('a' + i)));
    append_frame(frames, sent.back());
  }
  ASSERT_TRUE(send_packed(pair->first, frames).has_value());
  Reader r;
  std::size_t datagrams = 0;
  std::size_t seen = 0;
  for (;;) {
    auto got = r.reader.next_frame(pair->second, 0, sys::Wait::No);
    ASSERT_TRUE(got.has_value());
    if (!*got) break;
    if ((*got)->first) ++datagrams;
    ASSERT_LT(seen, sent.size());
    ASSERT_EQ((*got)->bytes.size(), sent[seen].size());
    EXPECT_EQ(std::memcmp((*got)->bytes.data(), sent[seen].data(), sent[seen].size()), 0);
    ++seen;
  }
  EXPECT_EQ(seen, sent.size());
  const std::size_t per_datagram = wire::kMaxFrameBytes / wire::aligned_frame_size(sent[0].size());
  EXPECT_EQ(datagrams, (sent.size() + per_datagram - 1) / per_datagram);
}

TEST(Transport, FullChannel_UnsentAtDatagramBoundaryWithEagain) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  ASSERT_TRUE(pair.has_value());
  const auto big = log_frame(wire::kMaxLogText, 'x');
  for (int i = 0; i < 100000 && pair->first.send(big).has_value(); ++i) {
  }
  std::vector<std::byte> frames;
  append_frame(frames, big);
  auto sent = send_packed(pair->first, frames);
  ASSERT_FALSE(sent.has_value());
  EXPECT_EQ(sent.error().error.error, EAGAIN);
  EXPECT_EQ(sent.error().sent, 0U);
}

// What a reader's first frame from a new pair says after `write` acted on the pair's writing end.
struct FirstFrame {
  bool closed = false;
  bool truncated = false;
  std::size_t bytes = 0;
};
template <class Write>
FirstFrame first_frame_after(Write&& write) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  EXPECT_TRUE(pair.has_value());
  if (!pair) return {};
  write(pair->first);
  Reader r;
  auto got = r.reader.next_frame(pair->second, 0, sys::Wait::No);
  EXPECT_TRUE(got.has_value() && got->has_value());
  if (!got || !*got) return {};
  return {.closed = (*got)->receipt->closed, .truncated = (*got)->receipt->truncated, .bytes = (*got)->bytes.size()};
}

TEST(Transport, PeerClosed_ReceiptClosed) {
  const FirstFrame got = first_frame_after([](sys::SeqPacket& writer) { writer.close(); });
  EXPECT_TRUE(got.closed);
  EXPECT_EQ(got.bytes, 0U);
}

TEST(Transport, OversizeDatagram_TruncatedEmptyFrame) {
  const FirstFrame got = first_frame_after([](sys::SeqPacket& writer) {
    EXPECT_TRUE(writer.send(std::vector<std::byte>(wire::kMaxFrameBytes + 100, std::byte{1})).has_value());
  });
  EXPECT_TRUE(got.truncated);
  EXPECT_EQ(got.bytes, 0U);
}

TEST(Transport, Forget_DropsWhatWasReadAhead) {
  auto pair = sys::SeqPacket::pair(sys::Blocking::No);
  ASSERT_TRUE(pair.has_value());
  const auto a = log_frame(1, 'a');
  ASSERT_TRUE(pair->first.send(a).has_value());
  ASSERT_TRUE(pair->first.send(a).has_value());
  Reader r;
  auto first = r.reader.next_frame(pair->second, 0, sys::Wait::No);
  ASSERT_TRUE(first.has_value() && first->has_value());
  EXPECT_TRUE(r.reader.buffered());  // the second datagram came in the same burst
  r.reader.forget();
  EXPECT_FALSE(r.reader.buffered());
  auto none = r.reader.next_frame(pair->second, 0, sys::Wait::No);
  ASSERT_TRUE(none.has_value());
  EXPECT_FALSE(none->has_value());
}

}  // namespace
}  // namespace rejuv::channel
