// The ground link codec (services/ext_link/link_protocol.hpp, docs/link_protocol.md) and ext_link's logic:
// well-formed datagrams round-trip; every kind of malformed datagram is refused with its reason and has no
// effect.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string_view>
#include <vector>

#include "rejuv/services/ext_link/ext_link.hpp"
#include "rejuv/services/ext_link/link_protocol.hpp"

namespace rejuv {
namespace {

using link::DecodeError;
using link::Direction;
using Bytes = std::vector<std::byte>;

link::MissionUpload square_upload() {
  link::MissionUpload up;
  up.count = 4;
  up.acceptance_radius_m = 0.1;
  up.waypoints[0] = {.north_m = 0, .east_m = 0, .down_m = -3, .yaw_rad = 0};
  up.waypoints[1] = {.north_m = 2, .east_m = 0, .down_m = -3, .yaw_rad = 0.5};
  up.waypoints[2] = {.north_m = 2, .east_m = 2, .down_m = -3, .yaw_rad = 1.0};
  up.waypoints[3] = {.north_m = 0, .east_m = 2, .down_m = -3, .yaw_rad = -1.0};
  return up;
}

// Home at 3 m over the origin, the default bounds (10 m geofence, 1 m altitude floor): square_upload passes.
services::ExtLink guarded_link() {
  return services::ExtLink({.home = {.p_N_m = Eigen::Vector3d(0, 0, -3), .yaw_rad = 0}, .bounds = {}});
}

Bytes bytes_of(const link::Message& m) {
  const link::Datagram d = link::encode(m);
  return Bytes(d.view().begin(), d.view().end());
}

Bytes upload_bytes(std::uint32_t sequence = 7) { return bytes_of({.sequence = sequence, .body = square_upload()}); }

// Recomputes the checksum after a test edited a datagram, so that the check under test is the one that fails.
void resign(Bytes& b) {
  for (std::size_t i = 12; i < 16 && i < b.size(); ++i) b[i] = std::byte{0};
  const std::uint32_t crc = link::crc32(b);
  for (unsigned i = 0; i < 4 && 12 + i < b.size(); ++i) b[12 + i] = std::byte{static_cast<std::uint8_t>(crc >> (8U * i))};
}

void put_u32(Bytes& b, std::size_t at, std::uint32_t v) {
  for (unsigned i = 0; i < 4; ++i) b[at + i] = std::byte{static_cast<std::uint8_t>(v >> (8U * i))};
}
void put_f64(Bytes& b, std::size_t at, double v) {
  const auto bits = std::bit_cast<std::uint64_t>(v);
  for (unsigned i = 0; i < 8; ++i) b[at + i] = std::byte{static_cast<std::uint8_t>(bits >> (8U * i))};
}

DecodeError refusal(const Bytes& b, Direction d = Direction::ToVehicle) {
  auto r = link::decode(b, d);
  EXPECT_FALSE(r.has_value());
  return r ? DecodeError::TooShort : r.error();
}

// ---- codec: well-formed ----

TEST(LinkCodec, Crc32_MatchesTheStandardCheckValue) {
  const std::string_view text = "123456789";
  EXPECT_EQ(link::crc32(std::as_bytes(std::span(text.data(), text.size()))), 0xCBF43926U);
}

TEST(LinkCodec, Header_IsLittleEndianFixedLayout) {
  const Bytes b = upload_bytes(0x01020304U);
  ASSERT_EQ(b.size(), 16U + 16U + 4U * 32U);
  EXPECT_EQ(b[0], std::byte{'R'});
  EXPECT_EQ(b[3], std::byte{'K'});
  EXPECT_EQ(b[4], std::byte{1});                                   // version
  EXPECT_EQ(b[5], std::byte{2});                                   // MissionUpload
  EXPECT_EQ(std::to_integer<int>(b[6]) | std::to_integer<int>(b[7]) << 8, 16 + 4 * 32);  // body length
  EXPECT_EQ(b[8], std::byte{0x04});                                // sequence, least significant first
  EXPECT_EQ(b[11], std::byte{0x01});
  EXPECT_EQ(b[16], std::byte{4});                                  // count
}

TEST(LinkCodec, EveryType_RoundTrips) {
  link::Telemetry t;
  t.time_ns = 123456789;
  t.p_N_m = {1, 2, -3};
  t.v_N_m_s = {0.1, 0.2, 0.3};
  t.setpoint_N_m = {1, 1, -3};
  t.setpoint_yaw_rad = 0.25;
  t.waypoint_index = 3;
  t.sr_mode = 2;
  t.mission_done = 1;
  t.epoch = 9;
  t.security_events = 11;
  t.link_refused = 12;
  t.uploads_forwarded = 13;
  const std::vector<std::pair<link::Message, Direction>> cases{
      {{.sequence = 1, .body = link::Hello{}}, Direction::ToVehicle},
      {{.sequence = 2, .body = square_upload()}, Direction::ToVehicle},
      {{.sequence = 3, .body = link::MissionAck{.upload_sequence = 2, .status = link::AckStatus::Forwarded}},
       Direction::ToGround},
      {{.sequence = 4, .body = t}, Direction::ToGround},
      {{.sequence = 5,
        .body = link::MissionAck{.upload_sequence = 2,
                                 .status = link::AckStatus::Refused,
                                 .reason = link::RefusalReason::OutsideGeofence,
                                 .waypoint = 3}},
       Direction::ToGround},
  };
  for (const auto& [message, direction] : cases) {
    const link::Datagram d = link::encode(message);
    auto back = link::decode(d.view(), direction);
    ASSERT_TRUE(back.has_value()) << link::to_string(back.error());
    EXPECT_EQ(*back, message);
  }
}

TEST(LinkCodec, UploadOfSixteenWaypoints_FitsTheGateLimit) {
  link::MissionUpload up;
  up.count = 16;
  const Bytes b = bytes_of({.sequence = 1, .body = up});
  EXPECT_LE(b.size(), link::kMaxLinkDatagramBytes);
  EXPECT_TRUE(link::decode(b, Direction::ToVehicle).has_value());
}

// The negative acknowledgement uses the bytes version 1 reserved: a Forwarded ack is byte for byte what it
// was (status 0, then three zero bytes), a Refused one carries the reason and the waypoint at fault.
TEST(LinkCodec, MissionAck_ForwardedUnchangedRefusedCarriesReasonAndWaypoint) {
  const Bytes forwarded = bytes_of({.sequence = 1, .body = link::MissionAck{.upload_sequence = 0x0A0B0C0DU}});
  ASSERT_EQ(forwarded.size(), 16U + 8U);
  EXPECT_EQ(forwarded[16], std::byte{0x0D});
  EXPECT_EQ(forwarded[20], std::byte{0});  // Forwarded
  EXPECT_EQ(forwarded[21], std::byte{0});
  EXPECT_EQ(forwarded[22], std::byte{0});
  EXPECT_EQ(forwarded[23], std::byte{0});
  Bytes refused = bytes_of({.sequence = 1,
                            .body = link::MissionAck{.upload_sequence = 9,
                                                     .status = link::AckStatus::Refused,
                                                     .reason = link::RefusalReason::BelowAltitudeFloor,
                                                     .waypoint = 15}});
  EXPECT_EQ(refused[20], std::byte{1});  // Refused
  EXPECT_EQ(refused[21], std::byte{4});  // BelowAltitudeFloor
  EXPECT_EQ(refused[22], std::byte{15});
  EXPECT_EQ(refused[23], std::byte{0});
  // ... which decodes only with a waypoint an upload can have (16 and 0x0102 cannot be one).
  for (const std::uint16_t waypoint : {std::uint16_t{16}, std::uint16_t{0x0102}}) {
    refused[22] = std::byte{static_cast<std::uint8_t>(waypoint & 0xFFU)};
    refused[23] = std::byte{static_cast<std::uint8_t>(waypoint >> 8U)};
    resign(refused);
    EXPECT_EQ(refusal(refused, Direction::ToGround), DecodeError::OutOfRange) << waypoint;
  }
}

TEST(LinkCodec, MissionAck_UnknownStatusOrReason_OutOfRange) {
  for (const auto& [status, reason] : {std::pair{2, 1}, std::pair{0xFF, 1}, std::pair{1, 0}, std::pair{1, 5}}) {
    Bytes ack = bytes_of({.sequence = 1, .body = link::MissionAck{}});
    ack[20] = std::byte{static_cast<std::uint8_t>(status)};
    ack[21] = std::byte{static_cast<std::uint8_t>(reason)};
    resign(ack);
    EXPECT_EQ(refusal(ack, Direction::ToGround), DecodeError::OutOfRange) << status << "/" << reason;
  }
}

// ---- codec: malformed (one test per reason) ----

TEST(LinkCodec, Empty_And_ShorterThanHeader_TooShort) {
  EXPECT_EQ(refusal({}), DecodeError::TooShort);
  const Bytes b = upload_bytes();
  EXPECT_EQ(refusal(Bytes(b.begin(), b.begin() + 15)), DecodeError::TooShort);
}

TEST(LinkCodec, LongerThanGateLimit_TooLong) {
  Bytes b = upload_bytes();
  b.resize(link::kMaxLinkDatagramBytes + 1);
  EXPECT_EQ(refusal(b), DecodeError::TooLong);
}

TEST(LinkCodec, BadMagic_Refused) {
  Bytes b = upload_bytes();
  b[0] = std::byte{'X'};
  resign(b);
  EXPECT_EQ(refusal(b), DecodeError::BadMagic);
}

TEST(LinkCodec, OtherVersion_Refused) {
  for (const std::uint8_t v : {0, 2, 255}) {
    Bytes b = upload_bytes();
    b[4] = std::byte{v};
    resign(b);
    EXPECT_EQ(refusal(b), DecodeError::BadVersion) << int{v};
  }
}

TEST(LinkCodec, UnknownType_Refused) {
  for (const std::uint8_t t : {0, 5, 200, 255}) {
    Bytes b = upload_bytes();
    b[5] = std::byte{t};
    resign(b);
    EXPECT_EQ(refusal(b), DecodeError::UnknownType) << int{t};
  }
}

TEST(LinkCodec, VehicleTypesSentToVehicle_WrongDirection) {
  const Bytes ack = bytes_of({.sequence = 1, .body = link::MissionAck{}});
  const Bytes tel = bytes_of({.sequence = 1, .body = link::Telemetry{}});
  EXPECT_EQ(refusal(ack), DecodeError::WrongDirection);
  EXPECT_EQ(refusal(tel), DecodeError::WrongDirection);
  EXPECT_EQ(refusal(upload_bytes(), Direction::ToGround), DecodeError::WrongDirection);
}

TEST(LinkCodec, TrailingByte_BadLength) {
  Bytes b = upload_bytes();
  b.push_back(std::byte{0});
  resign(b);
  EXPECT_EQ(refusal(b), DecodeError::BadLength);
}

TEST(LinkCodec, BodyLengthFieldDisagrees_BadLength) {
  Bytes b = upload_bytes();
  b[6] = std::byte{static_cast<std::uint8_t>(std::to_integer<int>(b[6]) - 32)};  // claims 3 waypoints
  resign(b);
  EXPECT_EQ(refusal(b), DecodeError::BadLength);
}

TEST(LinkCodec, CountDisagreesWithBody_BadLength) {
  Bytes b = upload_bytes();
  put_u32(b, 16, 3);  // four waypoints in the body, count says three
  resign(b);
  EXPECT_EQ(refusal(b), DecodeError::BadLength);
}

TEST(LinkCodec, HelloWithBody_BadLength) {
  Bytes b = bytes_of({.sequence = 1, .body = link::Hello{}});
  b.push_back(std::byte{1});
  b[6] = std::byte{1};
  resign(b);
  EXPECT_EQ(refusal(b), DecodeError::BadLength);
}

TEST(LinkCodec, AnySingleBitFlipped_Refused) {
  const Bytes good = upload_bytes();
  for (std::size_t i = 0; i < good.size(); ++i) {
    for (unsigned bit = 0; bit < 8; ++bit) {
      Bytes b = good;
      b[i] ^= std::byte{static_cast<std::uint8_t>(1U << bit)};
      EXPECT_FALSE(link::decode(b, Direction::ToVehicle).has_value()) << "byte " << i << " bit " << bit;
    }
  }
}

TEST(LinkCodec, BodyBitFlipped_BadChecksum) {
  Bytes b = upload_bytes();
  b[40] ^= std::byte{0x10};
  EXPECT_EQ(refusal(b), DecodeError::BadChecksum);
}

TEST(LinkCodec, ReservedNotZero_Refused) {
  Bytes b = upload_bytes();
  put_u32(b, 20, 1);  // the upload's reserved word
  resign(b);
  EXPECT_EQ(refusal(b), DecodeError::BadReserved);
  Bytes ack = bytes_of({.sequence = 1, .body = link::MissionAck{}});
  ack[21] = std::byte{1};
  resign(ack);
  EXPECT_EQ(refusal(ack, Direction::ToGround), DecodeError::BadReserved);
}

TEST(LinkCodec, CountZeroOrAboveSixteen_BadCount) {
  for (const std::uint32_t count : {0U, 17U, 1000U, 0xFFFF'FFFFU}) {
    Bytes b = upload_bytes();
    put_u32(b, 16, count);
    resign(b);
    EXPECT_EQ(refusal(b), DecodeError::BadCount) << count;
  }
}

TEST(LinkCodec, NonFiniteNumber_Refused) {
  const double bad[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity()};
  // acceptance radius, then the first and the last coordinate of the waypoints
  for (const std::size_t at : {std::size_t{24}, std::size_t{32}, std::size_t{16 + 16 + 4 * 32 - 8}}) {
    for (const double v : bad) {
      Bytes b = upload_bytes();
      put_f64(b, at, v);
      resign(b);
      EXPECT_EQ(refusal(b), DecodeError::NonFinite) << "offset " << at;
    }
  }
}

TEST(LinkCodec, AcceptanceRadiusNotPositive_OutOfRange) {
  for (const double r : {0.0, -0.0, -1.0}) {
    Bytes b = upload_bytes();
    put_f64(b, 24, r);
    resign(b);
    EXPECT_EQ(refusal(b), DecodeError::OutOfRange) << r;
  }
}

TEST(LinkCodec, TelemetryWithUnknownMode_OutOfRange) {
  Bytes b = bytes_of({.sequence = 1, .body = link::Telemetry{}});
  b[16 + 92] = std::byte{5};
  resign(b);
  EXPECT_EQ(refusal(b, Direction::ToGround), DecodeError::OutOfRange);
}

TEST(LinkCodec, EveryPrefixOfAValidDatagram_Refused) {
  const Bytes good = upload_bytes();
  for (std::size_t n = 0; n < good.size(); ++n) {
    EXPECT_FALSE(link::decode(std::span(good).first(n), Direction::ToVehicle).has_value()) << n;
  }
}

TEST(LinkCodec, RandomBytes_AlwaysRefusedNeverCrash) {
  std::uint64_t x = 12345;
  const auto next = [&] {
    x ^= x << 13U;
    x ^= x >> 7U;
    x ^= x << 17U;
    return x;
  };
  for (int i = 0; i < 20000; ++i) {
    Bytes b(next() % 600);
    for (std::byte& v : b) v = std::byte{static_cast<std::uint8_t>(next())};
    if (i % 2 == 0 && b.size() >= 6) {  // half with a valid magic and version, to get past the first checks
      b[0] = std::byte{'R'}, b[1] = std::byte{'J'}, b[2] = std::byte{'L'}, b[3] = std::byte{'K'}, b[4] = std::byte{1};
    }
    EXPECT_FALSE(link::decode(b, Direction::ToVehicle).has_value());
  }
}

// ---- ext_link's logic ----

TEST(ExtLink, Hello_MakesTheGroundKnown) {
  services::ExtLink link = guarded_link();
  EXPECT_FALSE(link.ground_known());
  auto r = link.on_datagram(bytes_of({.sequence = 1, .body = link::Hello{}}), Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(std::holds_alternative<services::ExtLink::GroundHello>(*r));
  EXPECT_TRUE(link.ground_known());
}

TEST(ExtLink, Upload_ForwardsTheWaypointsAndAcknowledgesItsSequence) {
  services::ExtLink link = guarded_link();
  auto r = link.on_datagram(upload_bytes(42), std::chrono::seconds{3});
  ASSERT_TRUE(r.has_value());
  const auto* forward = std::get_if<services::ExtLink::Forward>(&*r);
  ASSERT_NE(forward, nullptr);
  EXPECT_EQ(forward->sequence, 42U);
  EXPECT_EQ(forward->upload.count, 4U);
  EXPECT_EQ(forward->upload.timestamp_ns, 3'000'000'000U);
  EXPECT_DOUBLE_EQ(forward->upload.acceptance_radius_m, 0.1);
  EXPECT_DOUBLE_EQ(forward->upload.waypoints[2].p_N_m[1], 2.0);
  EXPECT_DOUBLE_EQ(forward->upload.waypoints[3].yaw_rad, -1.0);
  const link::Datagram ack = link.forwarded(*forward);
  auto decoded = link::decode(ack.view(), Direction::ToGround);
  ASSERT_TRUE(decoded.has_value());
  const auto* a = std::get_if<link::MissionAck>(&decoded->body);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->upload_sequence, 42U);
  EXPECT_EQ(link.uploads_forwarded(), 1U);
}

TEST(ExtLink, RetransmittedUpload_ReacknowledgedNotRepublished) {
  services::ExtLink link = guarded_link();
  auto first = link.on_datagram(upload_bytes(5), Nanos{0});
  ASSERT_TRUE(first.has_value());
  (void)link.forwarded(std::get<services::ExtLink::Forward>(*first));
  auto again = link.on_datagram(upload_bytes(5), Nanos{1});
  ASSERT_TRUE(again.has_value());
  EXPECT_TRUE(std::holds_alternative<services::ExtLink::Reacknowledge>(*again));
  auto next = link.on_datagram(upload_bytes(6), Nanos{2});  // a new upload (new sequence) is forwarded
  ASSERT_TRUE(next.has_value());
  EXPECT_TRUE(std::holds_alternative<services::ExtLink::Forward>(*next));
  EXPECT_EQ(link.uploads_forwarded(), 1U);
}

// Issue 18 item 5: an upload commander would refuse is refused here too, with the reason, so that the ground
// station learns it (it used to be acknowledged as forwarded and then dropped by commander, silently).
TEST(ExtLink, UploadOutsideTheBounds_RefusedWithItsReasonNotForwarded) {
  services::ExtLink link = guarded_link();
  struct Case {
    link::MissionUpload upload;
    link::RefusalReason reason;
    std::uint16_t waypoint;
  };
  std::vector<Case> cases;
  link::MissionUpload far = square_upload();
  far.waypoints[2].east_m = 12;  // 12 m east of home: outside the 10 m geofence
  cases.push_back({far, link::RefusalReason::OutsideGeofence, 2});
  link::MissionUpload low = square_upload();
  low.waypoints[1].down_m = -0.5;  // 0.5 m up: below the 1 m floor
  cases.push_back({low, link::RefusalReason::BelowAltitudeFloor, 1});
  link::MissionUpload many;
  many.count = 16;  // the path flown starts at x_sp: at most 15 uploaded waypoints
  for (auto& w : many.waypoints) w = {.north_m = 1, .east_m = 1, .down_m = -3, .yaw_rad = 0};
  cases.push_back({many, link::RefusalReason::TooManyWaypoints, 0});
  std::uint32_t sequence = 100;
  for (const Case& c : cases) {
    auto r = link.on_datagram(bytes_of({.sequence = sequence, .body = c.upload}), Nanos{0});
    ASSERT_TRUE(r.has_value()) << "well-formed: not a link refusal";
    const auto* refuse = std::get_if<services::ExtLink::Refuse>(&*r);
    ASSERT_NE(refuse, nullptr) << link::to_string(c.reason);
    EXPECT_EQ(refuse->reason, c.reason);
    EXPECT_EQ(refuse->waypoint, c.waypoint);
    auto ack = link::decode(link.refused_upload(*refuse).view(), Direction::ToGround);
    ASSERT_TRUE(ack.has_value());
    const auto& a = std::get<link::MissionAck>(ack->body);
    EXPECT_EQ(a.upload_sequence, sequence);
    EXPECT_EQ(a.status, link::AckStatus::Refused);
    EXPECT_EQ(a.reason, c.reason);
    EXPECT_EQ(a.waypoint, c.waypoint);
    ++sequence;
  }
  EXPECT_EQ(link.uploads_forwarded(), 0U);
  EXPECT_EQ(link.uploads_refused(), 3U);
  EXPECT_EQ(link.refused(), 0U);  // the datagrams were valid: the ground station is known
  EXPECT_TRUE(link.ground_known());
  // The valid upload after them is forwarded.
  auto ok = link.on_datagram(upload_bytes(200), Nanos{0});
  ASSERT_TRUE(ok.has_value());
  EXPECT_TRUE(std::holds_alternative<services::ExtLink::Forward>(*ok));
}

TEST(ExtLink, MalformedDatagrams_CountedByReasonWithoutEffect) {
  services::ExtLink link = guarded_link();
  Bytes bad_magic = upload_bytes();
  bad_magic[1] = std::byte{0};
  Bytes bad_crc = upload_bytes();
  bad_crc[30] ^= std::byte{1};
  EXPECT_FALSE(link.on_datagram({}, Nanos{0}).has_value());
  EXPECT_FALSE(link.on_datagram(bad_magic, Nanos{0}).has_value());
  EXPECT_FALSE(link.on_datagram(bad_crc, Nanos{0}).has_value());
  EXPECT_FALSE(link.on_datagram(bytes_of({.sequence = 1, .body = link::Telemetry{}}), Nanos{0}).has_value());
  EXPECT_EQ(link.refused(), 4U);
  EXPECT_EQ(link.refused(DecodeError::TooShort), 1U);
  EXPECT_EQ(link.refused(DecodeError::BadMagic), 1U);
  EXPECT_EQ(link.refused(DecodeError::BadChecksum), 1U);
  EXPECT_EQ(link.refused(DecodeError::WrongDirection), 1U);
  EXPECT_FALSE(link.ground_known());  // nothing malformed counts as a ground station
  EXPECT_EQ(link.uploads_forwarded(), 0U);
}

TEST(ExtLink, Telemetry_ReportsStateSetpointModeAndCounts) {
  services::ExtLink link = guarded_link();
  (void)link.on_datagram({}, Nanos{0});  // one refusal
  rejuv_msg_VehicleStateEstimate x{};
  x.p_N_m[0] = 0.5;
  x.p_N_m[2] = -2.9;
  x.v_N_m_s[1] = 0.2;
  rejuv_msg_Setpoint sp{};
  sp.p_N_m[0] = 1;
  sp.p_N_m[2] = -3;
  sp.waypoint_index = 2;
  sp.mission_done = 1;
  const link::Datagram d = link.telemetry({.now = std::chrono::milliseconds{1500}, .state = &x, .setpoint = &sp,
                                           .mode = SrMode::MC, .epoch = Epoch{3}, .security_events = 7});
  auto decoded = link::decode(d.view(), Direction::ToGround);
  ASSERT_TRUE(decoded.has_value());
  const auto& t = std::get<link::Telemetry>(decoded->body);
  EXPECT_EQ(t.time_ns, 1'500'000'000U);
  EXPECT_DOUBLE_EQ(t.p_N_m[0], 0.5);
  EXPECT_DOUBLE_EQ(t.p_N_m[2], -2.9);
  EXPECT_DOUBLE_EQ(t.v_N_m_s[1], 0.2);
  EXPECT_DOUBLE_EQ(t.setpoint_N_m[2], -3.0);
  EXPECT_EQ(t.waypoint_index, 2U);
  EXPECT_EQ(t.mission_done, 1);
  EXPECT_EQ(t.sr_mode, 0);
  EXPECT_EQ(t.epoch, 3U);
  EXPECT_EQ(t.security_events, 7U);
  EXPECT_EQ(t.link_refused, 1U);
}

TEST(ExtLink, RefusalLog_AtMostOncePerSecondOfKernelTime) {
  services::ExtLink link = guarded_link();
  std::uint64_t suppressed = 99;
  EXPECT_TRUE(link.should_log_refusal(Nanos{0}, suppressed));
  EXPECT_EQ(suppressed, 0U);
  EXPECT_FALSE(link.should_log_refusal(std::chrono::milliseconds{10}, suppressed));
  EXPECT_FALSE(link.should_log_refusal(std::chrono::milliseconds{999}, suppressed));
  EXPECT_TRUE(link.should_log_refusal(std::chrono::milliseconds{1000}, suppressed));
  EXPECT_EQ(suppressed, 2U);
}

}  // namespace
}  // namespace rejuv
