#include "rejuv/mavlink/messages.hpp"

#include <algorithm>
#include <bit>
#include <cstring>


namespace rejuv::mavlink {

namespace {

// Every message's CRC_EXTRA as computed from its field list equals the spec's; its payload fits a frame.
template <class... M>
constexpr bool all_crc_extras_match(std::variant<M...>*) {
  return ((crc_extra<M>() == M::kSpecCrcExtra && payload_bytes<M>() <= kMaxPayloadBytes) && ...);
}
static_assert(all_crc_extras_match(static_cast<Message*>(nullptr)), "a message's field list disagrees with the spec");

template <class T>
void put(std::byte* at, const T& v) {
  if constexpr (std::is_same_v<T, float>) {
    put(at, std::bit_cast<std::uint32_t>(v));
  } else if constexpr (std::is_arithmetic_v<T>) {
    using U = std::make_unsigned_t<T>;
    const U u = static_cast<U>(v);
    for (std::size_t i = 0; i < sizeof(T); ++i) at[i] = std::byte{static_cast<std::uint8_t>(u >> (8U * i))};
  } else {
    // An array: its elements in order, each little-endian.
    for (std::size_t i = 0; i < v.size(); ++i) put(at + i * sizeof(v[0]), v[i]);
  }
}

template <class T>
void get(const std::byte* at, T& v) {
  if constexpr (std::is_same_v<T, float>) {
    std::uint32_t u = 0;
    get(at, u);
    v = std::bit_cast<float>(u);
  } else if constexpr (std::is_arithmetic_v<T>) {
    using U = std::make_unsigned_t<T>;
    U u = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) u = static_cast<U>(u | (U{std::to_integer<std::uint8_t>(at[i])} << (8U * i)));
    v = static_cast<T>(u);
  } else {
    for (std::size_t i = 0; i < v.size(); ++i) get(at + i * sizeof(v[0]), v[i]);
  }
}

struct Known {
  std::uint32_t id = 0;
  std::uint8_t crc_extra = 0;
  std::size_t payload_bytes = 0;
  Result<Message, DecodeError> (*decode)(std::span<const std::byte> payload) = nullptr;
};

template <class M>
Result<Message, DecodeError> decode_as(std::span<const std::byte> payload) {
  // Zero-extension (spec "Empty-Byte Payload Truncation"): the receiver fills what was truncated with zeros.
  std::array<std::byte, kMaxPayloadBytes> full{};
  std::copy(payload.begin(), payload.end(), full.begin());
  M m{};
  std::size_t at = 0;
  M::each(m, [&](std::string_view, auto& v) {
    get(full.data() + at, v);
    at += sizeof(v);
  });
  return Message{m};
}

template <class... M>
constexpr std::array<Known, sizeof...(M)> table_of(std::variant<M...>*) {
  return {Known{.id = M::kId, .crc_extra = crc_extra<M>(), .payload_bytes = payload_bytes<M>(), .decode = &decode_as<M>}...};
}
constexpr auto kKnown = table_of(static_cast<Message*>(nullptr));

const Known* find(std::uint32_t msgid) {
  const auto it = std::find_if(kKnown.begin(), kKnown.end(), [&](const Known& k) { return k.id == msgid; });
  return it == kKnown.end() ? nullptr : &*it;
}

}  // namespace

std::string_view to_string(MissionResult result) {
  switch (result) {
    case MissionResult::Accepted: return "MAV_MISSION_ACCEPTED";
    case MissionResult::Error: return "MAV_MISSION_ERROR";
    case MissionResult::UnsupportedFrame: return "MAV_MISSION_UNSUPPORTED_FRAME";
    case MissionResult::Unsupported: return "MAV_MISSION_UNSUPPORTED";
    case MissionResult::NoSpace: return "MAV_MISSION_NO_SPACE";
    case MissionResult::Invalid: return "MAV_MISSION_INVALID";
    case MissionResult::InvalidParam1: return "MAV_MISSION_INVALID_PARAM1";
    case MissionResult::InvalidParam2: return "MAV_MISSION_INVALID_PARAM2";
    case MissionResult::InvalidParam3: return "MAV_MISSION_INVALID_PARAM3";
    case MissionResult::InvalidParam4: return "MAV_MISSION_INVALID_PARAM4";
    case MissionResult::InvalidParam5X: return "MAV_MISSION_INVALID_PARAM5_X";
    case MissionResult::InvalidParam6Y: return "MAV_MISSION_INVALID_PARAM6_Y";
    case MissionResult::InvalidParam7: return "MAV_MISSION_INVALID_PARAM7";
    case MissionResult::InvalidSequence: return "MAV_MISSION_INVALID_SEQUENCE";
    case MissionResult::Denied: return "MAV_MISSION_DENIED";
    case MissionResult::OperationCancelled: return "MAV_MISSION_OPERATION_CANCELLED";
  }
  return "?";
}

std::string_view to_string(DecodeError error) {
  switch (error) {
    case DecodeError::TooShort: return "shorter than a MAVLink 2 frame";
    case DecodeError::TooLong: return "longer than a MAVLink 2 frame";
    case DecodeError::BadStart: return "not a MAVLink 2 frame (start byte not 0xFD)";
    case DecodeError::BadIncompatFlags: return "unknown incompat flags";
    case DecodeError::BadLength: return "datagram size disagrees with the payload length";
    case DecodeError::UnknownMessage: return "unknown message id";
    case DecodeError::PayloadTooLong: return "payload longer than the message";
    case DecodeError::BadChecksum: return "bad checksum";
  }
  return "?";
}

std::uint32_t id_of(const Message& message) {
  return std::visit([](const auto& m) { return std::remove_cvref_t<decltype(m)>::kId; }, message);
}

std::string_view name_of(const Message& message) {
  return std::visit([](const auto& m) { return std::remove_cvref_t<decltype(m)>::kName; }, message);
}

std::optional<std::uint8_t> crc_extra_of(std::uint32_t msgid) {
  const Known* k = find(msgid);
  if (k == nullptr) return std::nullopt;
  return k->crc_extra;
}

Frame encode(const Message& message, const Envelope& envelope) {
  Frame f;
  std::size_t full = 0;
  std::uint8_t extra = 0;
  std::visit(
      [&](const auto& m) {
        using M = std::remove_cvref_t<decltype(m)>;
        std::size_t at = kHeaderBytes;
        M::each(m, [&](std::string_view, const auto& v) {
          put(f.bytes.data() + at, v);
          at += sizeof(v);
        });
        full = payload_bytes<M>();
        extra = crc_extra<M>();
      },
      message);
  // Trailing zeros are not sent; the first payload byte always is (spec "Empty-Byte Payload Truncation").
  std::size_t n = full;
  while (n > 1 && f.bytes[kHeaderBytes + n - 1] == std::byte{0}) --n;
  const std::uint32_t id = id_of(message);
  const std::array<std::uint8_t, kHeaderBytes> header{
      kStx, static_cast<std::uint8_t>(n), 0, 0, envelope.seq, envelope.sysid,
      envelope.compid, static_cast<std::uint8_t>(id), static_cast<std::uint8_t>(id >> 8U), static_cast<std::uint8_t>(id >> 16U)};
  for (std::size_t i = 0; i < header.size(); ++i) f.bytes[i] = std::byte{header[i]};
  const std::uint16_t crc = frame_checksum(std::span<const std::byte>(f.bytes.data(), kHeaderBytes + n), extra);
  f.bytes[kHeaderBytes + n] = std::byte{static_cast<std::uint8_t>(crc)};
  f.bytes[kHeaderBytes + n + 1] = std::byte{static_cast<std::uint8_t>(crc >> 8U)};
  f.size = kHeaderBytes + n + kChecksumBytes;
  return f;
}

Result<CheckedFrame, DecodeError> check_frame(std::span<const std::byte> datagram) {
  auto frame = split_frame(datagram);
  if (!frame) {
    switch (frame.error()) {
      case FrameError::TooShort: return fail(DecodeError::TooShort);
      case FrameError::TooLong: return fail(DecodeError::TooLong);
      case FrameError::BadStart: return fail(DecodeError::BadStart);
      case FrameError::BadIncompatFlags: return fail(DecodeError::BadIncompatFlags);
      case FrameError::BadLength: return fail(DecodeError::BadLength);
    }
    return fail(DecodeError::BadLength);
  }
  const Known* known = find(frame->header.msgid);
  if (known == nullptr) return fail(DecodeError::UnknownMessage);
  if (frame->payload.size() > known->payload_bytes) return fail(DecodeError::PayloadTooLong);
  if (frame_checksum(datagram.first(kHeaderBytes + frame->payload.size()), known->crc_extra) != frame->checksum) {
    return fail(DecodeError::BadChecksum);
  }
  return CheckedFrame{.frame = *frame, .crc_extra = known->crc_extra};
}

Result<Packet, DecodeError> decode(std::span<const std::byte> datagram) {
  auto checked = check_frame(datagram);
  if (!checked) return fail(checked.error());
  const FrameView& frame = checked->frame;
  auto message = find(frame.header.msgid)->decode(frame.payload);
  if (!message) return fail(message.error());
  return Packet{.header = frame.header, .message = std::move(*message), .signature = frame.signature};
}

std::string text_of(const StatusText& status) {
  const auto end = std::find(status.text.begin(), status.text.end(), '\0');
  return std::string(status.text.begin(), end);
}

StatusText status_text(Severity severity, std::string_view text) {
  StatusText s{};
  s.severity = static_cast<std::uint8_t>(severity);
  std::copy_n(text.begin(), std::min(text.size(), s.text.size()), s.text.begin());
  return s;
}

}  // namespace rejuv::mavlink
