// The kernel's decoding of an Invoke frame per object kind (kernel_sim/kernel/src/invocation.hpp): every
// operation of cap::kOperations decodes to the invocation of its row's kind, with its arguments typed, and every
// malformed argument to a precise error, answered before or after the cap is looked at (docs/protocol.md
// "Order of the checks of an Invoke").
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <limits>
#include <variant>

#include "invocation.hpp"
#include "rejuv/kernel/kernel.hpp"

namespace rejuv::kernel {
namespace {

using cap::Operation;

wire::InvokeHeader header(Operation op, std::uint64_t arg0 = 0, std::uint64_t arg1 = 0) {
  wire::InvokeHeader h{};
  h.operation = static_cast<std::uint8_t>(op);
  h.arg0 = arg0;
  h.arg1 = arg1;
  return h;
}

// The variant alternative each object kind decodes to.
std::size_t alternative_of(const cap::Requirement& need) {
  if (need.any_kind) return 0;  // CapInvocation
  switch (need.kind) {
    case ObjectKind::Checkpoint: return 1;
    case ObjectKind::Network: return 2;
    case ObjectKind::Limits: return 3;
    case ObjectKind::Persistent: return 4;
    case ObjectKind::Mode: return 5;
    case ObjectKind::Topic: break;
  }
  return std::variant_npos;
}

TEST(Invocation, EveryOperationDecodesToTheInvocationOfItsKind) {
  const std::array<std::byte, 8> data{};
  for (const cap::OperationSpec& row : cap::kOperations) {
    SCOPED_TRACE(std::string(cap::to_string(row.op)));
    // Arguments every operation accepts: own slot 1, rights R, a relayed datagram 1 judged valid, mode MC.
    const auto decoded = decode_invocation(row.op, header(row.op, 1, 1), data);
    if (!row.need.any_kind && row.need.kind == ObjectKind::Topic) {
      ASSERT_FALSE(decoded.has_value());  // Publish and Subscribe have their own frames
      EXPECT_EQ(decoded.error().error, wire::OpError::BadArgument);
      EXPECT_TRUE(decoded.error().before_authority);
      continue;
    }
    ASSERT_TRUE(decoded.has_value());
    EXPECT_EQ(decoded->index(), alternative_of(row.need));
  }
}

TEST(Invocation, ArgumentsAreTyped) {
  const std::array<std::byte, 3> data{std::byte{1}, std::byte{2}, std::byte{3}};
  auto arm = decode_invocation(Operation::TimerArm, header(Operation::TimerArm, 250'000'000, 1), {});
  ASSERT_TRUE(arm.has_value());
  const auto& timer = std::get<CheckpointInvocation::ArmTimer>(std::get<CheckpointInvocation>(*arm).what);
  EXPECT_EQ(timer.delay, Nanos{250'000'000});
  EXPECT_TRUE(timer.periodic);

  auto mint = decode_invocation(Operation::Mint, header(Operation::Mint, (std::uint64_t{1} << 63U) | 4U, (7U << 8U) | 3U), {});
  ASSERT_TRUE(mint.has_value());
  const auto& args = std::get<cap::MintArgs>(std::get<CapInvocation>(*mint).args);
  EXPECT_EQ(std::get<cap::Transfer>(args.to).to, ServiceId(4));
  EXPECT_EQ(args.mask, Rights{Right::Read} | Right::Write);
  EXPECT_EQ(args.badge, cap::Badge(7));

  auto read = decode_invocation(Operation::PersistentRead, header(Operation::PersistentRead, 16, 0), {});
  ASSERT_TRUE(read.has_value());
  const auto& r = std::get<PersistentInvocation::Read>(std::get<PersistentInvocation>(*read).what);
  EXPECT_EQ(r.offset, 16U);
  EXPECT_EQ(r.length, 0U);  // to the end of the cell

  auto send = decode_invocation(Operation::NetSend, header(Operation::NetSend), data);
  ASSERT_TRUE(send.has_value());
  EXPECT_EQ(std::get<NetInvocation::Send>(std::get<NetInvocation>(*send).what).datagram.size(), 3U);

  auto mode = decode_invocation(Operation::ModeRequest, header(Operation::ModeRequest, 4), {});
  ASSERT_TRUE(mode.has_value());
  EXPECT_EQ(std::get<ModeInvocation>(*mode).mode, SrMode::CP);
}

TEST(Invocation, MalformedArgumentsArePreciseErrors) {
  const auto refused = [](Operation op, std::uint64_t arg0, std::uint64_t arg1, std::span<const std::byte> data,
                          bool before_authority) {
    SCOPED_TRACE(std::string(cap::to_string(op)));
    const auto decoded = decode_invocation(op, header(op, arg0, arg1), data);
    ASSERT_FALSE(decoded.has_value());
    EXPECT_EQ(decoded.error().error, wire::OpError::BadArgument);
    EXPECT_EQ(decoded.error().before_authority, before_authority);
  };
  std::vector<std::byte> big(kMaxLimitsBytes + 1);
  std::vector<std::byte> datagram(wire::kMaxDatagramBytes + 1);
  refused(Operation::Copy, 0x1'0000'0000ULL, 1, {}, true);  // an own slot beyond 32 bits
  refused(Operation::Mint, 0x1'0000'0000ULL, 1, {}, true);
  refused(Operation::TimerArm, std::uint64_t{std::numeric_limits<std::int64_t>::max()} + 1, 0, {}, false);
  refused(Operation::LimitsWrite, 0, 0, big, false);
  refused(Operation::NetSend, 0, 0, {}, false);        // an empty datagram
  refused(Operation::NetSend, 0, 0, datagram, false);  // too long
  refused(Operation::NetReceive, 0, 0, {}, false);     // datagram id 0 is none
  refused(Operation::NetReceive, 1, kNetVerdictCodes, {}, false);
  refused(Operation::ModeRequest, kModeCount, 0, {}, false);
  // The largest delay and the last verdict code are fine.
  EXPECT_TRUE(decode_invocation(Operation::TimerArm,
                                header(Operation::TimerArm, std::uint64_t{std::numeric_limits<std::int64_t>::max()}), {})
                  .has_value());
  EXPECT_TRUE(decode_invocation(Operation::NetReceive, header(Operation::NetReceive, 1, kNetVerdictCodes - 1), {})
                  .has_value());
  EXPECT_TRUE(decode_invocation(Operation::LimitsWrite, header(Operation::LimitsWrite),
                                std::span(big).first(kMaxLimitsBytes))
                  .has_value());
}

}  // namespace
}  // namespace rejuv::kernel
