#include "rejuv/services/ext_link/link_protocol.hpp"

#include <bit>
#include <algorithm>
#include <cmath>
#include <optional>

namespace rejuv::link {

namespace {

constexpr std::size_t kUploadFixedBytes = 16;
constexpr std::size_t kUploadWaypointBytes = 32;
constexpr std::size_t kAckBytes = 8;
constexpr std::size_t kTelemetryBytes = 128;
constexpr std::size_t kChecksumOffset = 12;
static_assert(kHeaderBytes + kUploadFixedBytes + kMaxUploadWaypoints * kUploadWaypointBytes <= kMaxLinkDatagramBytes);

// Little-endian writer into a Datagram (bounds are fixed by the types: checked once per message).
class Writer {
 public:
  explicit Writer(Datagram& d) : d_(d) {}
  void u8(std::uint8_t v) { d_.bytes[d_.size++] = std::byte{v}; }
  void u16(std::uint16_t v) {
    for (unsigned i = 0; i < 2; ++i) u8(static_cast<std::uint8_t>(v >> (8U * i)));
  }
  void u32(std::uint32_t v) {
    for (unsigned i = 0; i < 4; ++i) u8(static_cast<std::uint8_t>(v >> (8U * i)));
  }
  void u64(std::uint64_t v) {
    for (unsigned i = 0; i < 8; ++i) u8(static_cast<std::uint8_t>(v >> (8U * i)));
  }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }

 private:
  Datagram& d_;
};

// Little-endian reader over a span whose size the caller has checked.
class Reader {
 public:
  explicit Reader(std::span<const std::byte> b) : b_(b) {}
  std::uint8_t u8() { return std::to_integer<std::uint8_t>(b_[at_++]); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(read(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(read(4)); }
  std::uint64_t u64() { return read(8); }
  double f64() { return std::bit_cast<double>(u64()); }

 private:
  std::uint64_t read(unsigned n) {
    std::uint64_t v = 0;
    for (unsigned i = 0; i < n; ++i) v |= std::uint64_t{u8()} << (8U * i);
    return v;
  }
  std::span<const std::byte> b_;
  std::size_t at_ = 0;
};

std::size_t body_size(MessageType type, std::uint32_t count) {
  switch (type) {
    case MessageType::Hello: return 0;
    case MessageType::MissionUpload: return kUploadFixedBytes + kUploadWaypointBytes * count;
    case MessageType::MissionAck: return kAckBytes;
    case MessageType::Telemetry: return kTelemetryBytes;
  }
  return 0;
}

std::optional<MessageType> type_from_wire(std::uint8_t v) {
  switch (v) {
    case 1: return MessageType::Hello;
    case 2: return MessageType::MissionUpload;
    case 3: return MessageType::MissionAck;
    case 4: return MessageType::Telemetry;
    default: return std::nullopt;
  }
}

Result<Body, DecodeError> decode_upload(Reader& r, std::size_t body_length) {
  MissionUpload m;
  m.count = r.u32();
  if (m.count < 1 || m.count > kMaxUploadWaypoints) return fail(DecodeError::BadCount);
  if (body_length != body_size(MessageType::MissionUpload, m.count)) return fail(DecodeError::BadLength);
  if (r.u32() != 0) return fail(DecodeError::BadReserved);
  m.acceptance_radius_m = r.f64();
  if (!std::isfinite(m.acceptance_radius_m)) return fail(DecodeError::NonFinite);
  if (!(m.acceptance_radius_m > 0)) return fail(DecodeError::OutOfRange);
  for (std::uint32_t i = 0; i < m.count; ++i) {
    UploadWaypoint& w = m.waypoints[i];
    w.north_m = r.f64();
    w.east_m = r.f64();
    w.down_m = r.f64();
    w.yaw_rad = r.f64();
    if (!std::isfinite(w.north_m) || !std::isfinite(w.east_m) || !std::isfinite(w.down_m) || !std::isfinite(w.yaw_rad)) {
      return fail(DecodeError::NonFinite);
    }
  }
  return m;
}

Result<Body, DecodeError> decode_ack(Reader& r) {
  MissionAck a;
  a.upload_sequence = r.u32();
  const std::uint8_t status = r.u8();
  if (status == static_cast<std::uint8_t>(AckStatus::Forwarded)) {
    a.status = AckStatus::Forwarded;
    if (r.u8() != 0 || r.u16() != 0) return fail(DecodeError::BadReserved);
    return a;
  }
  if (status != static_cast<std::uint8_t>(AckStatus::Refused)) return fail(DecodeError::OutOfRange);
  a.status = AckStatus::Refused;
  const std::uint8_t reason = r.u8();
  if (reason < 1 || reason > kMaxRefusalReason) return fail(DecodeError::OutOfRange);
  a.reason = static_cast<RefusalReason>(reason);
  a.waypoint = r.u16();
  if (a.waypoint >= kMaxUploadWaypoints) return fail(DecodeError::OutOfRange);
  return a;
}

Result<Body, DecodeError> decode_telemetry(Reader& r) {
  Telemetry t;
  t.time_ns = r.u64();
  for (double& v : t.p_N_m) v = r.f64();
  for (double& v : t.v_N_m_s) v = r.f64();
  for (double& v : t.setpoint_N_m) v = r.f64();
  t.setpoint_yaw_rad = r.f64();
  t.waypoint_index = r.u32();
  t.sr_mode = r.u8();
  if (t.sr_mode > 4) return fail(DecodeError::OutOfRange);
  t.mission_done = r.u8();
  if (t.mission_done > 1) return fail(DecodeError::OutOfRange);
  if (r.u16() != 0) return fail(DecodeError::BadReserved);
  t.epoch = r.u32();
  if (r.u32() != 0) return fail(DecodeError::BadReserved);
  t.security_events = r.u64();
  t.link_refused = r.u64();
  t.uploads_forwarded = r.u64();
  return t;
}

}  // namespace

std::string_view to_string(MessageType type) {
  switch (type) {
    case MessageType::Hello: return "Hello";
    case MessageType::MissionUpload: return "MissionUpload";
    case MessageType::MissionAck: return "MissionAck";
    case MessageType::Telemetry: return "Telemetry";
  }
  return "?";
}

std::string_view to_string(RefusalReason reason) {
  switch (reason) {
    case RefusalReason::None: return "none";
    case RefusalReason::InvalidMission: return "not a valid mission";
    case RefusalReason::TooManyWaypoints: return "too many waypoints";
    case RefusalReason::OutsideGeofence: return "outside the geofence";
    case RefusalReason::BelowAltitudeFloor: return "below the altitude floor";
  }
  return "?";
}

std::string_view to_string(DecodeError error) {
  switch (error) {
    case DecodeError::TooShort: return "shorter than the header";
    case DecodeError::TooLong: return "longer than the maximum datagram";
    case DecodeError::BadMagic: return "bad magic";
    case DecodeError::BadVersion: return "unsupported version";
    case DecodeError::UnknownType: return "unknown message type";
    case DecodeError::WrongDirection: return "message type not accepted on this side";
    case DecodeError::BadLength: return "body length disagrees with the datagram or the type";
    case DecodeError::BadChecksum: return "bad checksum";
    case DecodeError::BadReserved: return "reserved field not zero";
    case DecodeError::BadCount: return "waypoint count outside 1..16";
    case DecodeError::NonFinite: return "non-finite number";
    case DecodeError::OutOfRange: return "value out of range";
  }
  return "?";
}

MessageType type_of(const Body& body) {
  struct Visitor {
    MessageType operator()(const Hello&) const { return MessageType::Hello; }
    MessageType operator()(const MissionUpload&) const { return MessageType::MissionUpload; }
    MessageType operator()(const MissionAck&) const { return MessageType::MissionAck; }
    MessageType operator()(const Telemetry&) const { return MessageType::Telemetry; }
  };
  return std::visit(Visitor{}, body);
}

Direction direction_of(MessageType type) {
  switch (type) {
    case MessageType::Hello:
    case MessageType::MissionUpload: return Direction::ToVehicle;
    case MessageType::MissionAck:
    case MessageType::Telemetry: return Direction::ToGround;
  }
  return Direction::ToVehicle;
}

std::uint32_t crc32(std::span<const std::byte> bytes) {
  std::uint32_t crc = 0xFFFF'FFFFU;
  for (const std::byte b : bytes) {
    crc ^= std::to_integer<std::uint32_t>(b);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1U) ^ (0xEDB8'8320U & (0U - (crc & 1U)));
  }
  return ~crc;
}

Datagram encode(const Message& message) {
  Datagram d;
  Writer w(d);
  const MessageType type = type_of(message.body);
  std::uint32_t count = 0;
  if (const auto* up = std::get_if<MissionUpload>(&message.body)) count = up->count;
  REJUV_ASSERT(count <= kMaxUploadWaypoints, "an upload holds at most 16 waypoints");
  if (const auto* ack = std::get_if<MissionAck>(&message.body); ack != nullptr && ack->status == AckStatus::Refused) {
    REJUV_ASSERT(ack->reason != RefusalReason::None && ack->waypoint < kMaxUploadWaypoints,
                 "a refusal names its reason and a waypoint of the upload");
  }
  for (const std::uint8_t m : kMagic) w.u8(m);
  w.u8(kLinkVersion);
  w.u8(static_cast<std::uint8_t>(type));
  w.u16(static_cast<std::uint16_t>(body_size(type, count)));
  w.u32(message.sequence);
  w.u32(0);  // checksum, filled below
  struct Visitor {
    Writer& w;
    void operator()(const Hello&) const {}
    void operator()(const MissionUpload& m) const {
      w.u32(m.count);
      w.u32(0);
      w.f64(m.acceptance_radius_m);
      for (std::uint32_t i = 0; i < m.count; ++i) {
        w.f64(m.waypoints[i].north_m);
        w.f64(m.waypoints[i].east_m);
        w.f64(m.waypoints[i].down_m);
        w.f64(m.waypoints[i].yaw_rad);
      }
    }
    void operator()(const MissionAck& a) const {
      w.u32(a.upload_sequence);
      w.u8(static_cast<std::uint8_t>(a.status));
      const bool refused = a.status == AckStatus::Refused;
      w.u8(refused ? static_cast<std::uint8_t>(a.reason) : 0);
      w.u16(refused ? a.waypoint : 0);
    }
    void operator()(const Telemetry& t) const {
      w.u64(t.time_ns);
      for (const double v : t.p_N_m) w.f64(v);
      for (const double v : t.v_N_m_s) w.f64(v);
      for (const double v : t.setpoint_N_m) w.f64(v);
      w.f64(t.setpoint_yaw_rad);
      w.u32(t.waypoint_index);
      w.u8(t.sr_mode);
      w.u8(t.mission_done);
      w.u16(0);
      w.u32(t.epoch);
      w.u32(0);
      w.u64(t.security_events);
      w.u64(t.link_refused);
      w.u64(t.uploads_forwarded);
    }
  };
  std::visit(Visitor{w}, message.body);
  const std::uint32_t crc = crc32(d.view());
  for (unsigned i = 0; i < 4; ++i) d.bytes[kChecksumOffset + i] = std::byte{static_cast<std::uint8_t>(crc >> (8U * i))};
  return d;
}

Result<Message, DecodeError> decode(std::span<const std::byte> datagram, Direction expected) {
  if (datagram.size() < kHeaderBytes) return fail(DecodeError::TooShort);
  if (datagram.size() > kMaxLinkDatagramBytes) return fail(DecodeError::TooLong);
  Reader r(datagram);
  for (const std::uint8_t m : kMagic) {
    if (r.u8() != m) return fail(DecodeError::BadMagic);
  }
  if (r.u8() != kLinkVersion) return fail(DecodeError::BadVersion);
  const auto type = type_from_wire(r.u8());
  if (!type) return fail(DecodeError::UnknownType);
  if (direction_of(*type) != expected) return fail(DecodeError::WrongDirection);
  const std::size_t body_length = r.u16();
  if (kHeaderBytes + body_length != datagram.size()) return fail(DecodeError::BadLength);
  Message message;
  message.sequence = r.u32();
  const std::uint32_t checksum = r.u32();
  // The checksum covers the datagram with its own field zeroed.
  std::array<std::byte, kMaxLinkDatagramBytes> copy{};
  std::copy(datagram.begin(), datagram.end(), copy.begin());
  std::fill_n(copy.begin() + kChecksumOffset, 4, std::byte{0});
  if (crc32(std::span<const std::byte>(copy.data(), datagram.size())) != checksum) return fail(DecodeError::BadChecksum);

  Result<Body, DecodeError> body = fail(DecodeError::UnknownType);
  switch (*type) {
    case MessageType::Hello: body = Hello{}; break;
    case MessageType::MissionUpload:
      if (body_length < kUploadFixedBytes) return fail(DecodeError::BadLength);
      body = decode_upload(r, body_length);
      break;
    case MessageType::MissionAck:
      if (body_length != kAckBytes) return fail(DecodeError::BadLength);
      body = decode_ack(r);
      break;
    case MessageType::Telemetry:
      if (body_length != kTelemetryBytes) return fail(DecodeError::BadLength);
      body = decode_telemetry(r);
      break;
  }
  if (*type == MessageType::Hello && body_length != 0) return fail(DecodeError::BadLength);
  if (!body) return fail(body.error());
  message.body = std::move(*body);
  return message;
}

}  // namespace rejuv::link
