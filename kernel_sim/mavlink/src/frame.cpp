#include "rejuv/mavlink/frame.hpp"

#include <algorithm>
#include <chrono>

#include "rejuv/mavlink/sha256.hpp"

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

std::array<std::uint8_t, 6> signature_of(const SigningKey& key, std::span<const std::byte> signed_bytes) {
  Sha256 h;
  h.update(std::span<const std::uint8_t>(key.bytes));
  h.update(signed_bytes);
  const Sha256Digest digest = h.finish();
  std::array<std::uint8_t, 6> out{};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = digest[i];
  return out;
}

bool signature_matches(const SigningKey& key, const FrameView& frame) {
  if (!frame.signature) return false;
  const auto expected = signature_of(key, frame.signed_bytes);
  std::uint8_t diff = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) diff = static_cast<std::uint8_t>(diff | (expected[i] ^ frame.signature->value[i]));
  return diff == 0;
}

Result<void, SigningRefusal> SignatureChecker::check(std::span<const std::byte> datagram, SigningTime local_clock) {
  auto frame = split_frame(datagram);
  if (!frame) return fail(SigningRefusal::NotMavlink);
  if (!frame->signature) return fail(SigningRefusal::Unsigned);
  if (!signature_matches(key_, *frame)) return fail(SigningRefusal::BadSignature);
  const Signature& sig = *frame->signature;
  const SigningTime local = std::max(local_, local_clock);
  // Timestamps are 48 bits on the wire: adding a minute cannot overflow.
  if (sig.timestamp + kWindow < local) return fail(SigningRefusal::Stale);
  const auto same = [&](const Stream& s) {
    return s.sysid == frame->header.sysid && s.compid == frame->header.compid && s.link_id == sig.link_id;
  };
  const std::span<Stream> all(streams_);
  const std::span<Stream> kept = all.first(stream_count_);
  auto stream = std::find_if(kept.begin(), kept.end(), same);
  if (stream != kept.end()) {
    if (sig.timestamp <= stream->last) return fail(SigningRefusal::Replayed);
  } else if (stream_count_ < streams_.size()) {
    stream = all.begin() + static_cast<std::ptrdiff_t>(stream_count_++);
  } else {
    // Full: reuse the entry of a stream already more than a minute behind (its replays are refused as stale).
    stream = std::find_if(kept.begin(), kept.end(), [&](const Stream& s) { return s.last + kWindow < local; });
    if (stream == kept.end()) return fail(SigningRefusal::TooManyStreams);
  }
  *stream = Stream{.sysid = frame->header.sysid, .compid = frame->header.compid, .link_id = sig.link_id, .last = sig.timestamp};
  local_ = std::max(local, sig.timestamp);
  return {};
}

}  // namespace rejuv::mavlink
