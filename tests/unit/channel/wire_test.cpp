#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "rejuv/channel/wire.hpp"

namespace rejuv::wire {
namespace {

std::vector<std::byte> raw(const FrameHeader& h, std::size_t payload_bytes) {
  std::vector<std::byte> bytes(sizeof(h) + payload_bytes);
  std::memcpy(bytes.data(), &h, sizeof(h));
  return bytes;
}

TEST(Wire, BuildDecode_RoundTrip) {
  FrameBuffer f;
  const TimerSpec spec{.id = 7, .first_ns = 1000, .period_ns = 4000000};
  ASSERT_TRUE(f.build_with(FrameKind::TimerArm, 0, 42, 0, spec));
  const auto view = decode(f.bytes(), Direction::ToKernel);
  ASSERT_TRUE(view.has_value());
  EXPECT_EQ(view->kind, FrameKind::TimerArm);
  EXPECT_EQ(view->header.seq, 42U);
  const auto back = payload_as<TimerSpec>(*view);
  EXPECT_EQ(back.id, 7U);
  EXPECT_EQ(back.period_ns, 4000000U);
}

TEST(Wire, Decode_TooShort) {
  const std::vector<std::byte> bytes(10);
  EXPECT_EQ(decode(bytes, Direction::ToKernel).error(), FrameError::TooShort);
}

TEST(Wire, Decode_TooLong) {
  FrameHeader h{.kind = 2, .length = static_cast<std::uint32_t>(kMaxFrameBytes)};
  EXPECT_EQ(decode(raw(h, kMaxFrameBytes), Direction::ToKernel).error(), FrameError::TooLong);
}

TEST(Wire, Decode_LengthMismatch) {
  FrameHeader h{.kind = static_cast<std::uint16_t>(FrameKind::Publish), .length = 100};
  EXPECT_EQ(decode(raw(h, 50), Direction::ToKernel).error(), FrameError::LengthMismatch);
}

TEST(Wire, Decode_UnknownKind) {
  FrameHeader h{.kind = 999};
  EXPECT_EQ(decode(raw(h, 0), Direction::ToKernel).error(), FrameError::UnknownKind);
}

TEST(Wire, Decode_WrongDirection) {
  FrameHeader h{.kind = static_cast<std::uint16_t>(FrameKind::Shutdown)};
  EXPECT_EQ(decode(raw(h, 0), Direction::ToKernel).error(), FrameError::WrongDirection);
}

TEST(Wire, Decode_BadFlags) {
  FrameHeader h{.kind = static_cast<std::uint16_t>(FrameKind::Idle), .flags = 1};
  EXPECT_EQ(decode(raw(h, 0), Direction::ToKernel).error(), FrameError::BadFlags);
}

TEST(Wire, Decode_BadPayloadSize) {
  FrameHeader h{.kind = static_cast<std::uint16_t>(FrameKind::TimerArm), .length = 3};
  EXPECT_EQ(decode(raw(h, 3), Direction::ToKernel).error(), FrameError::BadPayloadSize);
  FrameHeader empty_publish{.kind = static_cast<std::uint16_t>(FrameKind::Publish)};
  EXPECT_EQ(decode(raw(empty_publish, 0), Direction::ToKernel).error(), FrameError::BadPayloadSize);
}

TEST(Wire, Build_OversizedPayload_Refused) {
  FrameBuffer f;
  const std::vector<std::byte> big(kMaxPayloadBytes + 1);
  EXPECT_FALSE(f.build(FrameKind::Publish, 1, 0, 0, big));
  EXPECT_TRUE(f.bytes().empty());
}

TEST(Wire, ReadName_UnterminatedArray_Bounded) {
  BootCap cap;
  std::memset(cap.object, 'x', sizeof(cap.object));  // a hostile peer leaves out the NUL
  EXPECT_EQ(read_name(cap.object).size(), sizeof(cap.object));
  EXPECT_FALSE(copy_name(cap.object, std::string(100, 'y')));
  EXPECT_EQ(read_name(cap.object).size(), sizeof(cap.object) - 1);
}

TEST(Wire, Decode_RandomBytes_NeverAcceptsInconsistentFrames) {
  std::mt19937 rng(1234);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<std::size_t> len(0, 200);
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::byte> bytes(len(rng));
    for (auto& b : bytes) b = static_cast<std::byte>(byte(rng));
    const auto view = decode(bytes, Direction::ToKernel);
    if (view) {  // anything accepted is self-consistent
      EXPECT_EQ(view->payload.size() + sizeof(FrameHeader), bytes.size());
      EXPECT_EQ(direction_of(view->kind), Direction::ToKernel);
    }
  }
}

// ---- several frames in one datagram ----

std::vector<std::byte> packed(const std::vector<std::vector<std::byte>>& frames) {
  std::vector<std::byte> out;
  for (const auto& f : frames) {
    out.resize(aligned_frame_size(out.size()), std::byte{0});
    out.insert(out.end(), f.begin(), f.end());
  }
  return out;
}

std::vector<std::byte> frame_of(FrameKind kind, std::uint64_t aux, std::size_t payload_bytes) {
  FrameBuffer f;
  const std::vector<std::byte> payload(payload_bytes, std::byte{0x5A});
  EXPECT_TRUE(f.build(kind, 0, 0, aux, payload));
  return {f.bytes().begin(), f.bytes().end()};
}

TEST(Wire, NextFrame_SplitsPackedFramesAtAlignedOffsets) {
  // 24 + 13 bytes (padded to 40), 24 + 0, 24 + 17 (the last one unpadded).
  const auto a = frame_of(FrameKind::Log, 1, 13);
  const auto b = frame_of(FrameKind::Idle, 2, 0);
  const auto c = frame_of(FrameKind::Log, 3, 17);
  const auto datagram = packed({a, b, c});
  ASSERT_EQ(datagram.size(), 40U + 24U + 41U);
  std::size_t offset = 0;
  std::vector<std::uint64_t> seen;
  do {
    const auto view = decode(next_frame(datagram, offset), Direction::ToKernel);
    ASSERT_TRUE(view.has_value()) << to_string(view.error());
    seen.push_back(view->header.aux);
  } while (offset < datagram.size());
  EXPECT_EQ(seen, (std::vector<std::uint64_t>{1, 2, 3}));
  EXPECT_EQ(offset, datagram.size());
}

TEST(Wire, NextFrame_OneFrameDatagram_IsTheWholeDatagram) {
  const auto a = frame_of(FrameKind::Idle, 9, 0);
  std::size_t offset = 0;
  EXPECT_EQ(next_frame(a, offset).size(), a.size());
  EXPECT_EQ(offset, a.size());
}

TEST(Wire, NextFrame_ClaimedLengthBeyondTheDatagram_TakesTheRestAndFailsDecode) {
  FrameHeader h{.kind = static_cast<std::uint16_t>(FrameKind::Log), .flags = 0, .slot = 0, .seq = 0,
                .length = 4000, .aux = 0};
  const auto datagram = packed({frame_of(FrameKind::Idle, 1, 0), raw(h, 10)});
  std::size_t offset = 0;
  ASSERT_TRUE(decode(next_frame(datagram, offset), Direction::ToKernel).has_value());
  const auto rest = next_frame(datagram, offset);
  EXPECT_EQ(rest.size(), sizeof(FrameHeader) + 10);
  EXPECT_EQ(offset, datagram.size());
  EXPECT_EQ(decode(rest, Direction::ToKernel).error(), FrameError::LengthMismatch);
}

TEST(Wire, NextFrame_ShortTailAndEmptyDatagram_OneUndecodableFrame) {
  auto datagram = frame_of(FrameKind::Idle, 1, 0);
  datagram.insert(datagram.end(), 5, std::byte{0x11});  // 5 bytes after it: no room for a header
  std::size_t offset = 0;
  (void)next_frame(datagram, offset);
  const auto tail = next_frame(datagram, offset);
  EXPECT_EQ(tail.size(), 5U);
  EXPECT_EQ(decode(tail, Direction::ToKernel).error(), FrameError::TooShort);
  EXPECT_EQ(offset, datagram.size());
  const std::vector<std::byte> empty;
  offset = 0;
  EXPECT_TRUE(next_frame(empty, offset).empty());
  EXPECT_EQ(offset, 0U);
}

// A sender's queue of frames leaves in datagrams of whole frames, each at most kMaxFrameBytes.
TEST(Wire, DatagramPrefix_WholeFramesThatFitOneDatagram) {
  const auto small = frame_of(FrameKind::Log, 1, 13);                   // 40 bytes with its padding
  const auto big = frame_of(FrameKind::Log, 2, kMaxPayloadBytes - 8);  // kMaxFrameBytes - 8 bytes
  EXPECT_EQ(datagram_prefix(packed({small, small})), 40U + small.size());
  const auto queue = packed({small, big, small});
  const std::size_t first = datagram_prefix(queue);
  EXPECT_EQ(first, small.size());  // the big frame would take the datagram past kMaxFrameBytes
  const auto rest = std::span<const std::byte>(queue).subspan(aligned_frame_size(first));
  const std::size_t second = datagram_prefix(rest);
  EXPECT_LE(second, kMaxFrameBytes);
  EXPECT_EQ(second, big.size());  // the small one after it does not fit either
  EXPECT_EQ(datagram_prefix(rest.subspan(aligned_frame_size(second))), small.size());
  EXPECT_EQ(datagram_prefix({}), 0U);
}

TEST(Wire, NextFrame_RandomDatagrams_AlwaysAdvanceAndStayInside) {
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<std::size_t> len(1, 300);
  for (int i = 0; i < 5000; ++i) {
    std::vector<std::byte> bytes(len(rng));
    for (auto& b : bytes) b = static_cast<std::byte>(byte(rng));
    std::size_t offset = 0;
    std::size_t frames = 0;
    do {
      const std::size_t before = offset;
      const auto f = next_frame(bytes, offset);
      ASSERT_GT(offset, before);  // progress: a datagram ends after at most size/8 + 1 frames
      ASSERT_LE(offset, bytes.size());
      ASSERT_GE(f.data(), bytes.data());
      ASSERT_LE(f.data() + f.size(), bytes.data() + bytes.size());
      ++frames;
    } while (offset < bytes.size());
    EXPECT_LE(frames, bytes.size() / kFrameAlign + 1);
  }
}

}  // namespace
}  // namespace rejuv::wire
