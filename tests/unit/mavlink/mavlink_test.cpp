// The MAVLink 2 codec (kernel_sim/mavlink): FIPS 180-4 SHA-256 examples, the spec's CRC_EXTRA values, and
// frames made by an implementation Rejuv did not write (node-mavlink 2.3.0, tests/mavlink_client/
// make_vectors.js) — encode must produce them byte for byte and decode must read them back.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/mavlink/sha256.hpp"

namespace rejuv::mavlink {
namespace {

// node-mavlink's frames (make_vectors.js; its key 00112233…eeff twice).
constexpr std::string_view k_heartbeat = "fd090000070101000000020001000200810403e190";
constexpr std::string_view k_local_position_ned = "fd14000008010120000040e201000000c03f000010c0000040c00000003ece45";
constexpr std::string_view k_attitude = "fd1c00000901011e0000e8030000cdcccc3dcdcc4cbe0000c03f00000000000000000ad7233c10ef";
constexpr std::string_view k_statustext = "fd1f00000a0101fd000004726f6c6c6261636b20333a20726573746f72656420696e20312e32206d731631";
constexpr std::string_view k_mission_count = "fd0400000bffbe2c0000030001011e0e";
constexpr std::string_view k_mission_item_int = "fd2500000cffbe490000000000000000003f000000000000a03f1027000078ecffff000040c0020010000101010001fd8f";
constexpr std::string_view k_mission_ack = "fd0300000d01012f0000ffbe0dff9b";
constexpr std::string_view k_mission_request_int = "fd0400000e01013300000100ffbe9207";
constexpr std::string_view k_global_position_int = "fd1c00000f0101210000050000004c52401c44f4170540720700b80b0000f4ff03000000282361ad";
constexpr std::string_view k_sys_status = "fd1f0000100101010000200000002000000020000000f4013831ffff000000000000000000000000ffd446";
constexpr std::string_view k_mission_item_reached_zero = "fd0000001101012e00003626";
constexpr std::string_view k_mission_count_signed = "fd04010012ffbe2c000003000101cd9303e8e33cd6921f05a71a4407e3";
constexpr std::string_view k_mission_request_list = "fd02000013ffbe2b000001013bb9";
constexpr std::string_view kKeyHex = "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff";
// k_mission_count_signed's timestamp: 2026-01-01 00:00:00.010 UTC.
const SigningTime kVectorTime = SigningClock::from_sys(std::chrono::sys_days{std::chrono::year{2026} / 1 / 1} +
                                                       std::chrono::milliseconds{10});

std::vector<std::byte> from_hex(std::string_view hex) {
  std::vector<std::byte> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<std::byte>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16)));
  }
  return out;
}
std::string to_hex(std::span<const std::byte> bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (const std::byte b : bytes) {
    out += kDigits[std::to_integer<unsigned>(b) >> 4U];
    out += kDigits[std::to_integer<unsigned>(b) & 15U];
  }
  return out;
}
std::string to_hex(const Sha256Digest& d) { return to_hex(std::as_bytes(std::span(d))); }
std::span<const std::byte> bytes_of(std::string_view s) { return std::as_bytes(std::span(s.data(), s.size())); }

template <class M>
M decoded_as(std::string_view hex) {
  const auto bytes = from_hex(hex);
  auto p = decode(bytes);
  EXPECT_TRUE(p.has_value()) << (p ? "" : to_string(p.error()));
  if (!p) return M{};
  const M* m = std::get_if<M>(&p->message);
  EXPECT_NE(m, nullptr) << name_of(p->message);
  return m == nullptr ? M{} : *m;
}

TEST(Sha256, Fips180Examples_Match) {
  EXPECT_EQ(to_hex(sha256(bytes_of("abc"))), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(to_hex(sha256(bytes_of(""))), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(to_hex(sha256(bytes_of("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"))),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  const std::string million(1'000'000, 'a');
  EXPECT_EQ(to_hex(sha256(bytes_of(million))), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(CrcExtra, ComputedFromFields_EqualsSpec) {
  EXPECT_EQ(crc_extra<Heartbeat>(), 50);
  EXPECT_EQ(crc_extra<SysStatus>(), 124);
  EXPECT_EQ(crc_extra<MissionItemInt>(), 38);
  EXPECT_EQ(crc_extra<StatusText>(), 83);
  EXPECT_EQ(payload_bytes<MissionItemInt>(), 38U);
  EXPECT_EQ(payload_bytes<SysStatus>(), 43U);
  EXPECT_EQ(crc_extra_of(0), 50);
  EXPECT_FALSE(crc_extra_of(12345).has_value());
}

TEST(Encode, Heartbeat_EqualsNodeMavlink) {
  const Heartbeat hb{.custom_mode = 0x00010002, .type = kMavTypeQuadrotor, .autopilot = 0, .base_mode = 129,
                     .system_status = kMavStateActive, .mavlink_version = 3};
  EXPECT_EQ(to_hex(encode(hb, Envelope{.seq = 7, .sysid = 1, .compid = 1}).view()), k_heartbeat);
  EXPECT_EQ(decoded_as<Heartbeat>(k_heartbeat), hb);
}

TEST(Encode, LocalPositionNed_TruncatedLikeNodeMavlink) {
  const LocalPositionNed lp{.time_boot_ms = 123456, .x = 1.5F, .y = -2.25F, .z = -3, .vx = 0.125F, .vy = 0, .vz = 0};
  const Frame f = encode(lp, Envelope{.seq = 8, .sysid = 1, .compid = 1});
  EXPECT_EQ(to_hex(f.view()), k_local_position_ned);
  EXPECT_LT(f.size, kHeaderBytes + 28 + kChecksumBytes) << "trailing zero velocities are not sent";
  EXPECT_EQ(decoded_as<LocalPositionNed>(k_local_position_ned), lp);
}

TEST(Encode, EveryVector_RoundTripsByteForByte) {
  // decode then encode again with the same envelope gives node-mavlink's bytes (unsigned, non-empty payloads).
  for (const std::string_view hex : {k_attitude, k_statustext, k_mission_count, k_mission_item_int, k_mission_ack,
                                     k_mission_request_int, k_global_position_int, k_sys_status, k_mission_request_list}) {
    const auto bytes = from_hex(hex);
    auto p = decode(bytes);
    ASSERT_TRUE(p.has_value()) << hex << ": " << to_string(p.error());
    const Frame again = encode(p->message, Envelope{.seq = p->header.seq, .sysid = p->header.sysid, .compid = p->header.compid});
    EXPECT_EQ(to_hex(again.view()), hex) << name_of(p->message);
  }
}

TEST(Decode, MissionItemInt_FieldsAsNodeMavlinkWroteThem) {
  const MissionItemInt m = decoded_as<MissionItemInt>(k_mission_item_int);
  EXPECT_EQ(m.seq, 2);
  EXPECT_EQ(m.frame, kMavFrameLocalNed);
  EXPECT_EQ(m.command, kMavCmdNavWaypoint);
  EXPECT_EQ(m.autocontinue, 1);
  EXPECT_FLOAT_EQ(m.param2, 0.5F);
  EXPECT_FLOAT_EQ(m.param4, 1.25F);
  EXPECT_EQ(m.x, 10000);
  EXPECT_EQ(m.y, -5000);
  EXPECT_FLOAT_EQ(m.z, -3);
  const StatusText s = decoded_as<StatusText>(k_statustext);
  EXPECT_EQ(text_of(s), "rollback 3: restored in 1.2 ms");
  EXPECT_EQ(s.severity, static_cast<std::uint8_t>(Severity::Warning));
}

TEST(Decode, EmptyPayload_IsZeroExtended) {
  // node-mavlink truncates an all-zero payload to 0 bytes; the spec keeps one. Both must decode.
  const MissionItemReached r = decoded_as<MissionItemReached>(k_mission_item_reached_zero);
  EXPECT_EQ(r.seq, 0);
  EXPECT_EQ(encode(MissionItemReached{}, Envelope{}).size, kHeaderBytes + 1 + kChecksumBytes);
}

TEST(Signing, NodeMavlinkSignature_Verifies) {
  const auto key = SigningKey::from_hex(kKeyHex);
  ASSERT_TRUE(key.has_value());
  const auto bytes = from_hex(k_mission_count_signed);
  auto f = split_frame(bytes);
  ASSERT_TRUE(f.has_value());
  ASSERT_TRUE(f->signature.has_value());
  EXPECT_EQ(f->signature->link_id, 3);
  // 2026-01-01 00:00:00.010 UTC in 10 µs units since 2015-01-01.
  EXPECT_EQ(f->signature->timestamp.time_since_epoch().count(),
            (1767225600ULL - kUnixSecondsAtSigningEpoch) * 100'000ULL + 1000ULL);
  EXPECT_EQ(f->signature->timestamp, kVectorTime);
  EXPECT_TRUE(signature_matches(*key, *f));
  SigningKey other = *key;
  other.bytes[0] ^= 1U;
  EXPECT_FALSE(signature_matches(other, *f));
}

TEST(Signing, Encode_EqualsNodeMavlinkSignedFrame) {
  const auto key = SigningKey::from_hex(kKeyHex);
  ASSERT_TRUE(key.has_value());
  const MissionCount mc = decoded_as<MissionCount>(k_mission_count);
  const Signer signer{.key = *key, .link_id = 3, .timestamp = kVectorTime};
  EXPECT_EQ(to_hex(encode(mc, Envelope{.seq = 18, .sysid = 255, .compid = 190}, signer).view()), k_mission_count_signed);
  auto p = decode(from_hex(k_mission_count_signed));
  ASSERT_TRUE(p.has_value());
  EXPECT_TRUE(p->signature.has_value());
}

// The gate's way of signing the vehicle's frames: an unsigned frame signed afterwards equals one encoded signed
// (so node-mavlink verifies it: the test above), and only a well-formed unsigned frame is signed.
TEST(Signing, SignFrame_EqualsEncodedSignedAndRefusesWhatItCannotSign) {
  const auto key = SigningKey::from_hex(kKeyHex);
  ASSERT_TRUE(key.has_value());
  const MissionCount mc = decoded_as<MissionCount>(k_mission_count);
  const Signer signer{.key = *key, .link_id = 3, .timestamp = kVectorTime};
  const Frame plain = encode(mc, Envelope{.seq = 18, .sysid = 255, .compid = 190});
  const auto signed_frame = sign_frame(plain.view(), signer);
  ASSERT_TRUE(signed_frame.has_value());
  EXPECT_EQ(to_hex(signed_frame->view()), k_mission_count_signed);
  EXPECT_FALSE(sign_frame(signed_frame->view(), signer).has_value()) << "signed already";
  Frame bad = plain;
  bad.bytes[11] ^= std::byte{1};
  EXPECT_FALSE(sign_frame(bad.view(), signer).has_value()) << "bad checksum";
  EXPECT_FALSE(sign_frame(std::span<const std::byte>(plain.bytes.data(), 5), signer).has_value()) << "too short";
}

TEST(SigningKey, FromHex_RefusesWrongLengthAndNonHex) {
  EXPECT_FALSE(SigningKey::from_hex("0011").has_value());
  EXPECT_FALSE(SigningKey::from_hex(std::string(63, '0') + "g").has_value());
  EXPECT_TRUE(SigningKey::from_hex(std::string(64, 'A')).has_value());
}

// One test per decode error.
TEST(Decode, TooShort_Refused) { EXPECT_EQ(decode(from_hex("fd0000")).error(), DecodeError::TooShort); }
TEST(Decode, TooLong_Refused) {
  EXPECT_EQ(decode(std::vector<std::byte>(kMaxFrameBytes + 1, std::byte{0xFD})).error(), DecodeError::TooLong);
}
TEST(Decode, MavlinkOne_RefusedAsBadStart) {
  auto bytes = from_hex(k_heartbeat);
  bytes[0] = std::byte{0xFE};
  EXPECT_EQ(decode(bytes).error(), DecodeError::BadStart);
}
TEST(Decode, UnknownIncompatFlag_Refused) {
  auto bytes = from_hex(k_heartbeat);
  bytes[2] = std::byte{0x02};
  EXPECT_EQ(decode(bytes).error(), DecodeError::BadIncompatFlags);
}
TEST(Decode, SizeDisagreesWithLength_Refused) {
  auto bytes = from_hex(k_heartbeat);
  bytes.push_back(std::byte{0});
  EXPECT_EQ(decode(bytes).error(), DecodeError::BadLength);
  auto signed_flag = from_hex(k_heartbeat);
  signed_flag[2] = std::byte{kIncompatSigned};  // says 13 signature bytes follow; none do
  EXPECT_EQ(decode(signed_flag).error(), DecodeError::BadLength);
}
TEST(Decode, UnknownMessageId_Refused) {
  auto bytes = from_hex(k_heartbeat);
  bytes[7] = std::byte{0x99};
  EXPECT_EQ(decode(bytes).error(), DecodeError::UnknownMessage);
}
TEST(Decode, PayloadLongerThanMessage_Refused) {
  // MISSION_ITEM_REACHED is 2 bytes; a 3-byte payload is not it.
  std::vector<std::byte> bytes = from_hex("fd0300001101012e0000010203");
  bytes.push_back(std::byte{0});
  bytes.push_back(std::byte{0});
  EXPECT_EQ(decode(bytes).error(), DecodeError::PayloadTooLong);
}
TEST(Decode, FlippedPayloadBit_BadChecksum) {
  auto bytes = from_hex(k_mission_item_int);
  bytes[kHeaderBytes + 3] ^= std::byte{0x01};
  EXPECT_EQ(decode(bytes).error(), DecodeError::BadChecksum);
}

TEST(SigningClock, FromSys_TenMicrosecondTicksSinceTwentyFifteen) {
  using namespace std::chrono;
  const sys_days epoch{year{2015} / 1 / 1};
  EXPECT_EQ(SigningClock::from_sys(epoch).time_since_epoch().count(), 0U);
  EXPECT_EQ(SigningClock::from_sys(epoch + seconds{1} + microseconds{25}).time_since_epoch().count(), 100'002U);
  EXPECT_EQ(SigningClock::from_sys(sys_days{year{2014} / 6 / 1}).time_since_epoch().count(), 0U) << "before the epoch";
}
TEST(SigningClock, Now_IsTheWallClock) {
  const SigningTime before = SigningClock::from_sys(std::chrono::system_clock::now());
  const SigningTime now = SigningClock::now();
  const SigningTime after = SigningClock::from_sys(std::chrono::system_clock::now());
  EXPECT_LE(before, now);
  EXPECT_LE(now, after);
}

// The checker against a clock the test sets (the gate gives it the wall clock).
class SignatureCheckerTest : public ::testing::Test {
 protected:
  static constexpr SigningClock::duration kTick{1};
  // A signed HEARTBEAT of the stream (sysid, compid 1, link_id), stamped `t`.
  [[nodiscard]] Frame frame(SigningTime t, std::uint8_t sysid = 255, std::uint8_t link_id = 1) const {
    return encode(Heartbeat{}, Envelope{.sysid = sysid}, Signer{.key = key_, .link_id = link_id, .timestamp = t});
  }
  [[nodiscard]] Result<void, SigningRefusal> check(const Frame& f) { return checker_.check(f.view(), clock_); }
  const SigningKey key_ = *SigningKey::from_hex(kKeyHex);
  SignatureChecker checker_{key_};
  SigningTime clock_ = kVectorTime;
};

TEST_F(SignatureCheckerTest, Unsigned_Refused) {
  EXPECT_EQ(checker_.check(from_hex(k_mission_count), clock_).error(), SigningRefusal::Unsigned);
}
TEST_F(SignatureCheckerTest, NotMavlink_Refused) {
  EXPECT_EQ(checker_.check(from_hex("524a4c4b0100000000000000"), clock_).error(), SigningRefusal::NotMavlink);
}
TEST_F(SignatureCheckerTest, OtherKey_Refused) {
  SignatureChecker other(*SigningKey::from_hex(std::string(64, '1')));
  EXPECT_EQ(other.check(from_hex(k_mission_count_signed), clock_).error(), SigningRefusal::BadSignature);
}
TEST_F(SignatureCheckerTest, NodeMavlinkFrame_AcceptedThenItsReplayRefused) {
  EXPECT_TRUE(checker_.check(from_hex(k_mission_count_signed), clock_).has_value());
  EXPECT_EQ(checker_.check(from_hex(k_mission_count_signed), clock_).error(), SigningRefusal::Replayed);
}

// The attack the local clock stops: a frame signed with the right key but recorded long ago (here stamped at the
// signing epoch, 2015-01-01) is refused by a checker that has accepted nothing yet.
TEST_F(SignatureCheckerTest, FirstFrameStampedTwentyFifteen_RefusedAsStale) {
  EXPECT_EQ(check(frame(SigningTime{})).error(), SigningRefusal::Stale);
  EXPECT_EQ(check(frame(clock_ - std::chrono::hours{24})).error(), SigningRefusal::Stale);
  EXPECT_EQ(checker_.stream_count(), 0U);
}
TEST_F(SignatureCheckerTest, NewStreamMoreThanAMinuteBehindTheClock_RefusedAsStale) {
  EXPECT_EQ(check(frame(clock_ - SignatureChecker::kWindow - kTick)).error(), SigningRefusal::Stale);
}
TEST_F(SignatureCheckerTest, NewStreamWithinAMinuteOfTheClock_Accepted) {
  EXPECT_TRUE(check(frame(clock_ - SignatureChecker::kWindow, 1)).has_value()) << "one minute behind: not more";
  EXPECT_TRUE(check(frame(clock_ - std::chrono::seconds{59}, 2)).has_value());
  EXPECT_TRUE(check(frame(clock_, 3)).has_value());
  EXPECT_TRUE(check(frame(clock_ + std::chrono::seconds{5}, 4)).has_value()) << "a clock a little ahead";
}
TEST_F(SignatureCheckerTest, KnownStreamFallenMoreThanAMinuteBehind_RefusedAsStale) {
  ASSERT_TRUE(check(frame(clock_)).has_value());
  clock_ += std::chrono::minutes{2};
  EXPECT_EQ(check(frame(clock_ - std::chrono::minutes{2} + kTick)).error(), SigningRefusal::Stale);
}
TEST_F(SignatureCheckerTest, SameStream_StrictlyIncreasing) {
  ASSERT_TRUE(check(frame(clock_)).has_value());
  EXPECT_EQ(check(frame(clock_)).error(), SigningRefusal::Replayed) << "an equal timestamp";
  EXPECT_EQ(check(frame(clock_ - kTick)).error(), SigningRefusal::Replayed);
  EXPECT_TRUE(check(frame(clock_ + kTick)).has_value());
  EXPECT_EQ(check(frame(clock_ + kTick)).error(), SigningRefusal::Replayed);
}
TEST_F(SignatureCheckerTest, SeparateStreams_Independent) {
  // Three streams: another system id, another link id. Each is judged against its own last timestamp only.
  ASSERT_TRUE(check(frame(clock_ + std::chrono::seconds{1}, 255, 1)).has_value());
  EXPECT_TRUE(check(frame(clock_, 254, 1)).has_value()) << "older than stream 255's last, but its own first";
  EXPECT_TRUE(check(frame(clock_, 255, 2)).has_value()) << "another link";
  EXPECT_EQ(check(frame(clock_ + std::chrono::milliseconds{500}, 255, 1)).error(), SigningRefusal::Replayed);
  EXPECT_TRUE(check(frame(clock_ + kTick, 254, 1)).has_value());
  EXPECT_TRUE(check(frame(clock_ + kTick, 255, 2)).has_value());
  EXPECT_EQ(checker_.stream_count(), 3U);
}
TEST_F(SignatureCheckerTest, RefusedFrame_ChangesNothing) {
  ASSERT_TRUE(check(frame(clock_)).has_value());
  const SigningTime local = checker_.local_time();
  EXPECT_EQ(check(frame(SigningTime{}, 7)).error(), SigningRefusal::Stale);
  Frame forged = frame(clock_ + std::chrono::hours{1}, 8);
  forged.bytes[forged.size - 1] ^= std::byte{1};
  EXPECT_EQ(check(forged).error(), SigningRefusal::BadSignature);
  EXPECT_EQ(checker_.stream_count(), 1U);
  EXPECT_EQ(checker_.local_time(), local) << "a forged timestamp an hour ahead moved nothing";
}
// The spec's local timestamp follows the newest accepted one and never goes back, also when the clock does.
TEST_F(SignatureCheckerTest, LocalTime_FollowsAcceptedTimestampsNeverGoesBack) {
  ASSERT_TRUE(check(frame(clock_ + std::chrono::seconds{30})).has_value());
  EXPECT_EQ(checker_.local_time(), clock_ + std::chrono::seconds{30});
  clock_ -= std::chrono::minutes{10};  // the wall clock stepped back
  EXPECT_EQ(check(frame(clock_, 2)).error(), SigningRefusal::Stale);
  EXPECT_EQ(checker_.local_time(), kVectorTime + std::chrono::seconds{30});
}
// The table is bounded: with every entry live a new stream is refused and the kept ones go on; an entry whose
// stream has fallen more than a minute behind is reused, and that stream's old frames stay refused (as stale).
TEST_F(SignatureCheckerTest, StreamTable_BoundedLiveStreamsKept) {
  for (std::uint8_t link = 0; link < SignatureChecker::kMaxStreams; ++link) {
    ASSERT_TRUE(check(frame(clock_, 255, link)).has_value()) << int{link};
  }
  EXPECT_EQ(check(frame(clock_, 255, 200)).error(), SigningRefusal::TooManyStreams);
  EXPECT_EQ(checker_.stream_count(), SignatureChecker::kMaxStreams);
  EXPECT_TRUE(check(frame(clock_ + kTick, 255, 0)).has_value()) << "a kept stream goes on";
}
TEST_F(SignatureCheckerTest, StreamTable_FullOfStaleStreams_ReusesAnEntry) {
  const Frame first = frame(clock_, 255, 0);
  ASSERT_TRUE(check(first).has_value());
  for (std::uint8_t link = 1; link < SignatureChecker::kMaxStreams; ++link) {
    ASSERT_TRUE(check(frame(clock_ + std::chrono::minutes{2}, 255, link)).has_value()) << int{link};
  }
  clock_ += std::chrono::minutes{2};  // stream 0 is now two minutes behind, the others are live
  EXPECT_TRUE(check(frame(clock_, 255, 200)).has_value()) << "takes stream 0's entry";
  EXPECT_EQ(checker_.stream_count(), SignatureChecker::kMaxStreams);
  EXPECT_EQ(check(first).error(), SigningRefusal::Stale) << "the forgotten stream's frame is still refused";
  EXPECT_EQ(check(frame(clock_, 255, 201)).error(), SigningRefusal::TooManyStreams);
}

}  // namespace
}  // namespace rejuv::mavlink
