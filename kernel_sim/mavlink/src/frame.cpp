#include "rejuv/mavlink/frame.hpp"

#include <algorithm>
#include <chrono>


namespace rejuv::mavlink {

namespace {
std::uint8_t at(std::span<const std::byte> b, std::size_t i) { return std::to_integer<std::uint8_t>(b[i]); }

std::optional<std::uint8_t> hex_digit(char c) {
  if (c >= '0' && c <= '9') return static_cast<std::uint8_t>(c - '0');
  if (c >= 'a' && c <= 'f') return static_cast<std::uint8_t>(c - 'a' + 10);
  if (c >= 'A' && c <= 'F') return static_cast<std::uint8_t>(c - 'A' + 10);
  return std::nullopt;
}
}  // namespace

Result<SigningKey, std::string> SigningKey::from_hex(std::string_view hex) {
  SigningKey key;
  if (hex.size() != 2 * key.bytes.size()) {
    return fail("expected 64 hex digits (a 32-byte key), got " + std::to_string(hex.size()) + " characters");
  }
  for (std::size_t i = 0; i < key.bytes.size(); ++i) {
    const auto hi = hex_digit(hex[2 * i]);
    const auto lo = hex_digit(hex[2 * i + 1]);
    if (!hi || !lo) return fail("expected hex digits, got '" + std::string(hex.substr(2 * i, 2)) + "' at " + std::to_string(2 * i + 1));
    key.bytes[i] = static_cast<std::uint8_t>((*hi << 4U) | *lo);
  }
  return key;
}

SigningTime SigningClock::from_sys(std::chrono::system_clock::time_point t) {
  const auto since_unix = std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
  const std::int64_t us = since_unix - static_cast<std::int64_t>(kUnixSecondsAtSigningEpoch) * 1'000'000;
  return SigningTime{duration{us <= 0 ? 0 : static_cast<std::uint64_t>(us) / 10U}};
}

SigningTime SigningClock::now() { return from_sys(std::chrono::system_clock::now()); }

std::string_view to_string(FrameError error) {
  switch (error) {
    case FrameError::TooShort: return "shorter than a MAVLink 2 frame";
    case FrameError::TooLong: return "longer than a MAVLink 2 frame";
    case FrameError::BadStart: return "not a MAVLink 2 frame (start byte not 0xFD)";
    case FrameError::BadIncompatFlags: return "unknown incompat flags";
    case FrameError::BadLength: return "datagram size disagrees with the payload length";
  }
  return "?";
}

std::string_view to_string(SigningRefusal refusal) {
  switch (refusal) {
    case SigningRefusal::NotMavlink: return "not_mavlink";
    case SigningRefusal::Unsigned: return "unsigned";
    case SigningRefusal::BadSignature: return "bad_signature";
    case SigningRefusal::Replayed: return "replayed";
    case SigningRefusal::Stale: return "stale";
    case SigningRefusal::TooManyStreams: return "too_many_streams";
  }
  return "?";
}

Result<FrameView, FrameError> split_frame(std::span<const std::byte> d) {
  if (d.size() < kHeaderBytes + kChecksumBytes) return fail(FrameError::TooShort);
  if (d.size() > kMaxFrameBytes) return fail(FrameError::TooLong);
  if (at(d, 0) != kStx) return fail(FrameError::BadStart);
  FrameView f;
  f.header.payload_length = at(d, 1);
  f.header.incompat_flags = at(d, 2);
  f.header.compat_flags = at(d, 3);
  f.header.seq = at(d, 4);
  f.header.sysid = at(d, 5);
  f.header.compid = at(d, 6);
  f.header.msgid = std::uint32_t{at(d, 7)} | (std::uint32_t{at(d, 8)} << 8U) | (std::uint32_t{at(d, 9)} << 16U);
  if ((f.header.incompat_flags & ~kIncompatSigned) != 0) return fail(FrameError::BadIncompatFlags);
  const bool is_signed = (f.header.incompat_flags & kIncompatSigned) != 0;
  const std::size_t n = f.header.payload_length;
  if (d.size() != kHeaderBytes + n + kChecksumBytes + (is_signed ? kSignatureBytes : 0)) return fail(FrameError::BadLength);
  f.payload = d.subspan(kHeaderBytes, n);
  f.checksum = static_cast<std::uint16_t>(at(d, kHeaderBytes + n) | (at(d, kHeaderBytes + n + 1) << 8U));
  if (is_signed) {
    const std::size_t s = kHeaderBytes + n + kChecksumBytes;
    Signature sig;
    sig.link_id = at(d, s);
    std::uint64_t ticks = 0;
    for (std::size_t i = 0; i < 6; ++i) ticks |= std::uint64_t{at(d, s + 1 + i)} << (8U * i);
    sig.timestamp = SigningTime{SigningClock::duration{ticks}};
    for (std::size_t i = 0; i < 6; ++i) sig.value[i] = at(d, s + 7 + i);
    f.signature = sig;
    f.signed_bytes = d.first(d.size() - 6);
  }
  return f;
}

}  // namespace rejuv::mavlink
