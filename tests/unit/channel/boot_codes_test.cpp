// The channel's codecs that both ends use: the boot script (the kernel's encoder, the SDK's decoder) and the
// codes in fixed payload fields (reply codes, rights bits).
#include <gtest/gtest.h>

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "rejuv/channel/boot.hpp"
#include "rejuv/channel/codes.hpp"

namespace rejuv::channel {
namespace {

// The frames write_boot_script emits, each copied out of the shared FrameBuffer.
std::vector<std::vector<std::byte>> script_frames(const BootIdentity& who, std::span<const wire::BootCap> caps,
                                                  std::span<const wire::BootParam> params) {
  wire::FrameBuffer tx;
  std::vector<std::vector<std::byte>> frames;
  write_boot_script(tx, who, caps, params,
                    [&](std::span<const std::byte> f) { frames.emplace_back(f.begin(), f.end()); });
  return frames;
}

// Feeds every frame to a decoder; the result of the last take.
Result<bool, BootFailure> feed(BootDecoder& decoder, const std::vector<std::vector<std::byte>>& frames) {
  Result<bool, BootFailure> last = false;
  for (const auto& bytes : frames) {
    auto frame = wire::decode(bytes, wire::Direction::ToService);
    EXPECT_TRUE(frame.has_value());
    if (!frame) return false;
    last = decoder.take(*frame);
    if (!last) return last;
  }
  return last;
}

TEST(BootScript, KernelEncoderSdkDecoder_RoundTrip) {
  std::array<Rights, kModeCount> topic_rights{};
  topic_rights[index_of(SrMode::MC)] = Rights{Right::Read} | Right::Write;
  topic_rights[index_of(SrMode::SC)] = Right::Read;
  std::array<Rights, kModeCount> cell_rights{};
  cell_rights.fill(Rights::all());
  const std::vector<wire::BootCap> caps{
      encode_boot_cap(BootCapEntry{.slot = Slot(3), .kind = ObjectKind::Topic, .rights = topic_rights,
                                   .payload_size = 96, .object = "vehicle_state",
                                   .type = "rejuv::msg::VehicleStateEstimate"}),
      encode_boot_cap(BootCapEntry{.slot = Slot(255), .kind = ObjectKind::Persistent, .rights = cell_rights,
                                   .payload_size = 64, .object = "cell", .type = {}}),
  };
  const std::vector<wire::BootParam> params{
      encode_boot_param(BootParamEntry{.name = "gain", .number = 2.5, .text = {}, .is_text = false}),
      encode_boot_param(BootParamEntry{.name = "clock", .number = 0, .text = "lockstep", .is_text = true}),
  };
  const auto frames = script_frames(BootIdentity{.service = ServiceId(7), .epoch = Epoch(2), .name = "mc"}, caps, params);
  ASSERT_EQ(frames.size(), 1 + caps.size() + params.size() + 1);

  BootDecoder decoder;
  auto done = feed(decoder, frames);
  ASSERT_TRUE(done.has_value()) << to_string(done.error());
  EXPECT_TRUE(*done);
  EXPECT_EQ(decoder.identity().service, ServiceId(7));
  EXPECT_EQ(decoder.identity().epoch, Epoch(2));
  EXPECT_EQ(decoder.identity().name, "mc");
  ASSERT_EQ(decoder.cap_count(), 2U);
  const BootCapEntry topic = decoder.cap(0);
  EXPECT_EQ(topic.slot, Slot(3));
  EXPECT_EQ(topic.kind, ObjectKind::Topic);
  EXPECT_EQ(topic.rights, topic_rights);
  EXPECT_EQ(topic.payload_size, 96U);
  EXPECT_EQ(topic.object, "vehicle_state");
  EXPECT_EQ(topic.type, "rejuv::msg::VehicleStateEstimate");
  const BootCapEntry cell = decoder.cap(1);
  EXPECT_EQ(cell.slot, Slot(255));
  EXPECT_EQ(cell.kind, ObjectKind::Persistent);
  EXPECT_EQ(cell.rights, cell_rights);
  EXPECT_EQ(cell.type, "");
  ASSERT_EQ(decoder.param_count(), 2U);
  EXPECT_EQ(decoder.param(0).name, "gain");
  EXPECT_FALSE(decoder.param(0).is_text);
  EXPECT_DOUBLE_EQ(decoder.param(0).number, 2.5);
  EXPECT_EQ(decoder.param(1).name, "clock");
  EXPECT_TRUE(decoder.param(1).is_text);
  EXPECT_EQ(decoder.param(1).text, "lockstep");
}

TEST(BootScript, Empty_BootThenBootEnd) {
  const auto frames = script_frames(BootIdentity{.service = ServiceId(0), .epoch = Epoch(0), .name = "x"}, {}, {});
  ASSERT_EQ(frames.size(), 2U);
  BootDecoder decoder;
  auto done = feed(decoder, frames);
  ASSERT_TRUE(done.has_value());
  EXPECT_TRUE(*done);
  EXPECT_EQ(decoder.cap_count(), 0U);
  EXPECT_EQ(decoder.param_count(), 0U);
}

TEST(BootScript, FrameOutOfOrder_UnexpectedFrame) {
  wire::FrameBuffer tx;
  ASSERT_TRUE(tx.build(wire::FrameKind::BootEnd, 0, 0, 0));
  BootDecoder decoder;
  auto took = feed(decoder, {{tx.bytes().begin(), tx.bytes().end()}});
  ASSERT_FALSE(took.has_value());
  EXPECT_EQ(took.error().error, BootError::UnexpectedFrame);
  EXPECT_EQ(to_string(took.error()), "expected Boot, got BootEnd");
}

TEST(BootScript, OtherVersion_VersionMismatch) {
  wire::FrameBuffer tx;
  ASSERT_TRUE(tx.build_with(wire::FrameKind::Boot, 0, 0, wire::kProtocolVersion + 1, wire::BootHeader{}));
  BootDecoder decoder;
  auto took = feed(decoder, {{tx.bytes().begin(), tx.bytes().end()}});
  ASSERT_FALSE(took.has_value());
  EXPECT_EQ(took.error().error, BootError::VersionMismatch);
  EXPECT_EQ(took.error().found, wire::kProtocolVersion + 1U);
}

TEST(BootScript, SlotOutsideCSpace_SlotOutOfRange) {
  const std::vector<wire::BootCap> caps{encode_boot_cap(BootCapEntry{.slot = Slot(wire::kCSpaceSlots)})};
  const auto frames = script_frames(BootIdentity{}, caps, {});
  BootDecoder decoder;
  auto done = feed(decoder, frames);
  ASSERT_FALSE(done.has_value());
  EXPECT_EQ(done.error().error, BootError::SlotOutOfRange);
  EXPECT_EQ(done.error().found, wire::kCSpaceSlots);
}

TEST(ReplyCodes, EveryDenial_RoundTrips) {
  for (const cap::CapError e : cap::kAllCapErrors) {
    const std::int32_t code = denial_code(e);
    EXPECT_EQ(reply_kind(code), ReplyKind::Denied);
    EXPECT_EQ(denial_of(code), e);
  }
}

TEST(ReplyCodes, OkOperationAndUnknown_Sorted) {
  EXPECT_EQ(reply_kind(kReplyOk), ReplyKind::Ok);
  EXPECT_EQ(reply_kind(op_code(wire::OpError::Refused)), ReplyKind::OperationFailed);
  EXPECT_EQ(reply_kind(wire::kFirstOpError + 50), ReplyKind::OperationFailed);
  EXPECT_EQ(reply_kind(static_cast<std::int32_t>(cap::kCapErrorCount) + 1), ReplyKind::Unknown);
  EXPECT_EQ(reply_kind(-1), ReplyKind::Unknown);
  EXPECT_FALSE(denial_of(op_code(wire::OpError::BadArgument)).has_value());
}

TEST(RightsBits, EverySet_RoundTripsAndOtherBitsIgnored) {
  for (unsigned bits = 0; bits < 8; ++bits) {
    const Rights r = rights_from_bits(bits);
    EXPECT_EQ(rights_bits(r), bits);
    EXPECT_EQ(rights_from_bits(bits | 0xF0U), r);
  }
}

}  // namespace
}  // namespace rejuv::channel
