#include <gtest/gtest.h>

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

}  // namespace
}  // namespace rejuv::wire
