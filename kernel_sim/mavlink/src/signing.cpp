// Message signing (MAVLink spec "Message Signing"): the signature, its check, and signing a frame. In a file
// of its own so that a program that only encodes and decodes (ext_link, which never holds the key) links no
// SHA-256 and no libcrypto.
#include <algorithm>
#include <chrono>

#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/mavlink/sha256.hpp"

namespace rejuv::mavlink {

std::array<std::uint8_t, 6> signature_of(const SigningKey& key, std::span<const std::byte> signed_bytes) {
  const Sha256Digest digest = sha256({std::as_bytes(std::span(key.bytes)), signed_bytes});
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

std::optional<Frame> sign_frame(std::span<const std::byte> datagram, const Signer& signer) {
  // Well-formed (a known message whose checksum is right) and unsigned; its payload is not read.
  auto checked = check_frame(datagram);
  if (!checked || checked->frame.signature) return std::nullopt;
  const FrameView& frame = checked->frame;
  const std::size_t body = kHeaderBytes + frame.payload.size();
  Frame f;
  std::copy(datagram.begin(), datagram.begin() + static_cast<std::ptrdiff_t>(body), f.bytes.begin());
  f.bytes[2] = std::byte{static_cast<std::uint8_t>(frame.header.incompat_flags | kIncompatSigned)};
  const std::uint16_t crc = frame_checksum(std::span<const std::byte>(f.bytes.data(), body), checked->crc_extra);
  f.bytes[body] = std::byte{static_cast<std::uint8_t>(crc)};
  f.bytes[body + 1] = std::byte{static_cast<std::uint8_t>(crc >> 8U)};
  f.size = body + kChecksumBytes;
  f.bytes[f.size] = std::byte{signer.link_id};
  const std::uint64_t ticks = signer.timestamp.time_since_epoch().count();  // its low 48 bits go on the wire
  for (std::size_t i = 0; i < 6; ++i) f.bytes[f.size + 1 + i] = std::byte{static_cast<std::uint8_t>(ticks >> (8U * i))};
  const auto sig = signature_of(signer.key, std::span<const std::byte>(f.bytes.data(), f.size + 7));
  for (std::size_t i = 0; i < 6; ++i) f.bytes[f.size + 7 + i] = std::byte{sig[i]};
  f.size += kSignatureBytes;
  return f;
}

Frame encode(const Message& message, const Envelope& envelope, const std::optional<Signer>& signer) {
  Frame plain = encode(message, envelope);
  if (!signer) return plain;
  auto signed_frame = sign_frame(plain.view(), *signer);
  REJUV_ASSERT(signed_frame.has_value(), "a frame encode() made could not be signed");
  return *signed_frame;
}

}  // namespace rejuv::mavlink
