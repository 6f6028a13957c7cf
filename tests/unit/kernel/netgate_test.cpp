// The network gate's GroundLink (kernel_sim/kernel/src/netgate.hpp; docs/design.md §2; docs/mavlink.md "Signing",
// "Where the vehicle sends"): the signing check against the clock it is given, and the ground address, which
// only a valid verdict on a relayed datagram moves. The gate relays a datagram only after admit() passed it
// (netgate.cpp net_poll), so a refused one never gets an id a verdict could name; the multi-process test
// NetGateSigned.RecordedAndReplayedFrames_* shows the same by its effect on a running kernel.
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "netgate.hpp"
#include "rejuv/mavlink/messages.hpp"

namespace rejuv::kernel {
namespace {

namespace mav = rejuv::mavlink;
using Verdict = GroundLink::Verdict;

constexpr std::string_view kKeyHex = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";

class GroundLinkTest : public ::testing::Test {
 protected:
  [[nodiscard]] mav::Frame signed_heartbeat(mav::SigningTime t) const {
    return mav::encode(mav::Heartbeat{}, mav::Envelope{.sysid = 255, .compid = 190},
                       mav::Signer{.key = key_, .link_id = 1, .timestamp = t});
  }
  // What the gate does with a datagram from `from`: admit, then relay (record) what passed. The id it got.
  std::optional<std::uint64_t> offer(const mav::Frame& f, const sys::UdpAddress& from) {
    if (!link_.admit(f.view(), clock_)) return std::nullopt;
    const std::uint64_t id = link_.next_id();
    link_.relayed(from);
    return id;
  }
  const mav::SigningKey key_ = *mav::SigningKey::from_hex(kKeyHex);
  const sys::UdpAddress ground_ = sys::UdpAddress::loopback(14550);
  const sys::UdpAddress replayer_ = sys::UdpAddress::loopback(40000);
  // 2026-06-01 00:00 UTC: the wall clock as the test sets it.
  mav::SigningTime clock_ = mav::SigningClock::from_sys(std::chrono::sys_days{std::chrono::year{2026} / 6 / 1});
  GroundLink link_{key_, ground_};
};

TEST_F(GroundLinkTest, FrameStampedTwentyFifteen_RefusedAsStale) {
  EXPECT_EQ(link_.admit(signed_heartbeat(mav::SigningTime{}).view(), clock_).error(), mav::SigningRefusal::Stale);
}

TEST_F(GroundLinkTest, FrameStampedByTheClock_Admitted) {
  EXPECT_TRUE(link_.admit(signed_heartbeat(clock_).view(), clock_).has_value());
}

TEST_F(GroundLinkTest, WithoutKey_EverythingAdmitted) {
  GroundLink open;
  EXPECT_FALSE(open.signing());
  EXPECT_TRUE(open.admit(signed_heartbeat(mav::SigningTime{}).view(), clock_).has_value());
  EXPECT_FALSE(open.ground().has_value());
}

// A stale frame and a replayed one are refused before they are relayed, so nothing can judge them and the
// telemetry stays with the ground station; the ground station's own frame, judged valid, keeps it there.
TEST_F(GroundLinkTest, RefusedFrames_NeverChangeTheGroundAddress) {
  const mav::Frame valid = signed_heartbeat(clock_);
  const auto id = offer(valid, ground_);
  ASSERT_TRUE(id.has_value());
  ASSERT_TRUE(link_.judge(*id, Verdict::Valid).has_value());
  EXPECT_FALSE(offer(signed_heartbeat(mav::SigningTime{}), replayer_).has_value()) << "recorded in 2015";
  EXPECT_FALSE(offer(valid, replayer_).has_value()) << "the captured frame replayed";
  // The id the refused datagrams would have had was never handed out: a verdict naming it is refused.
  EXPECT_EQ(link_.judge(link_.next_id(), Verdict::Valid).error(), GroundLink::JudgeError::NotRelayed);
  ASSERT_TRUE(link_.ground().has_value());
  EXPECT_EQ(link_.ground()->to_string(), ground_.to_string());
}

TEST_F(GroundLinkTest, RefusedVerdict_KeepsTheGroundAddress) {
  const auto id = offer(signed_heartbeat(clock_), replayer_);
  ASSERT_TRUE(id.has_value());
  ASSERT_TRUE(link_.judge(*id, Verdict::Refused).has_value());
  EXPECT_EQ(link_.ground()->to_string(), ground_.to_string());
}

TEST_F(GroundLinkTest, ValidVerdict_MovesTheGroundAddressOnce) {
  const auto id = offer(signed_heartbeat(clock_), replayer_);
  ASSERT_TRUE(id.has_value());
  ASSERT_TRUE(link_.judge(*id, Verdict::Valid).has_value());
  EXPECT_EQ(link_.ground()->to_string(), replayer_.to_string());
  EXPECT_EQ(link_.judge(*id, Verdict::Valid).error(), GroundLink::JudgeError::NotRelayed) << "judged already";
}

TEST_F(GroundLinkTest, VerdictOnAnOverwrittenDatagram_Refused) {
  const auto first = offer(signed_heartbeat(clock_), replayer_);
  ASSERT_TRUE(first.has_value());
  for (std::size_t i = 1; i <= kRecentDatagrams; ++i) {
    ASSERT_TRUE(offer(signed_heartbeat(clock_ + mav::SigningClock::duration{i}), ground_).has_value());
  }
  EXPECT_EQ(link_.judge(*first, Verdict::Valid).error(), GroundLink::JudgeError::NotRelayed);
  EXPECT_EQ(link_.ground()->to_string(), ground_.to_string());
}

}  // namespace
}  // namespace rejuv::kernel
