// MAVLink 2 framing and message signing (MAVLink spec, "Packet Serialization" and "Message Signing",
// https://mavlink.io/en/guide/serialization.html, https://mavlink.io/en/guide/message_signing.html):
//
//   offset  size  field
//        0     1  STX 0xFD
//        1     1  payload length (0 … 255, after trailing-zero truncation)
//        2     1  incompat flags (0x01: signed; any other bit: a frame this implementation must refuse)
//        3     1  compat flags (ignored)
//        4     1  seq
//        5     1  sysid
//        6     1  compid
//        7     3  msgid (little-endian, 24 bits)
//       10     n  payload
//     10+n     2  checksum: CRC-16/MCRF4XX (X.25) of bytes 1 … 9+n, then the message's CRC_EXTRA byte
//     12+n    13  signature, when signed: link id (1), timestamp (6, little-endian, 10 µs units since
//                 2015-01-01 00:00 UTC), signature (6: the first 48 bits of SHA-256(key ‖ bytes 0 … 18+n))
//
// One frame per UDP datagram. This layer checks only the envelope (sizes, STX, flags) and signatures; the
// kernel's network gate uses it and nothing else, so it never interprets a payload. messages.hpp decodes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "rejuv/core/result.hpp"

namespace rejuv::mavlink {

inline constexpr std::uint8_t kStx = 0xFD;
inline constexpr std::size_t kHeaderBytes = 10;
inline constexpr std::size_t kChecksumBytes = 2;
inline constexpr std::size_t kSignatureBytes = 13;
inline constexpr std::size_t kMaxPayloadBytes = 255;
inline constexpr std::size_t kMaxFrameBytes = kHeaderBytes + kMaxPayloadBytes + kChecksumBytes + kSignatureBytes;
inline constexpr std::uint8_t kIncompatSigned = 0x01;

// CRC-16/MCRF4XX (the "X.25" checksum of the MAVLink spec): init 0xFFFF, reflected polynomial 0x8408.
class Crc16 {
 public:
  constexpr void add(std::uint8_t byte) {
    std::uint8_t tmp = byte ^ static_cast<std::uint8_t>(value_ & 0xFFU);
    tmp = static_cast<std::uint8_t>(tmp ^ static_cast<std::uint8_t>(tmp << 4U));
    value_ = static_cast<std::uint16_t>((value_ >> 8U) ^ (std::uint16_t{tmp} << 8U) ^ (std::uint16_t{tmp} << 3U) ^
                                        (tmp >> 4U));
  }
  constexpr void add(std::span<const std::byte> bytes) {
    for (const std::byte b : bytes) add(std::to_integer<std::uint8_t>(b));
  }
  [[nodiscard]] constexpr std::uint16_t value() const { return value_; }

 private:
  std::uint16_t value_ = 0xFFFF;
};

// The 32-byte secret key of message signing. Only the kernel's network gate and the ground station hold it.
struct SigningKey {
  std::array<std::uint8_t, 32> bytes{};
  // 64 hex digits (either case), nothing else.
  [[nodiscard]] static Result<SigningKey, std::string> from_hex(std::string_view hex);
  friend bool operator==(const SigningKey&, const SigningKey&) = default;
};

// The signature block of a signed frame.
struct Signature {
  std::uint8_t link_id = 0;
  std::uint64_t timestamp = 0;  // [10 µs] since 2015-01-01 00:00:00 UTC (48 bits)
  std::array<std::uint8_t, 6> value{};
  friend bool operator==(const Signature&, const Signature&) = default;
};
// The signing timestamp for a Unix time [10 µs units since the MAVLink epoch 2015-01-01].
inline constexpr std::uint64_t kUnixSecondsAtSigningEpoch = 1420070400;
[[nodiscard]] std::uint64_t signing_timestamp_now();

struct FrameHeader {
  std::uint8_t payload_length = 0;
  std::uint8_t incompat_flags = 0;
  std::uint8_t compat_flags = 0;
  std::uint8_t seq = 0;
  std::uint8_t sysid = 0;
  std::uint8_t compid = 0;
  std::uint32_t msgid = 0;  // 24 bits
  friend bool operator==(const FrameHeader&, const FrameHeader&) = default;
};

// A datagram split into its parts (views into it). The checksum is not checked here (it needs the message's
// CRC_EXTRA: messages.hpp), nor the signature (verify()).
struct FrameView {
  FrameHeader header{};
  std::span<const std::byte> payload{};
  std::uint16_t checksum = 0;
  std::optional<Signature> signature{};
  std::span<const std::byte> signed_bytes{};  // what the signature covers after the key: all but its 6 bytes
};

enum class FrameError : std::uint8_t {
  TooShort,         // shorter than a header and checksum
  TooLong,          // longer than the largest frame
  BadStart,         // not 0xFD (MAVLink 1 frames are not accepted)
  BadIncompatFlags, // an incompat flag other than "signed": the spec says such a frame must be dropped
  BadLength,        // the datagram's size disagrees with the payload length and the signed flag
};
inline constexpr std::size_t kFrameErrorCount = 5;
[[nodiscard]] std::string_view to_string(FrameError error);

[[nodiscard]] Result<FrameView, FrameError> split_frame(std::span<const std::byte> datagram);

// The 6 signature bytes of a frame whose other bytes are `signed_bytes` (header … link id and timestamp).
[[nodiscard]] std::array<std::uint8_t, 6> signature_of(const SigningKey& key, std::span<const std::byte> signed_bytes);
// Whether a signed frame's signature is the key's (constant time in the bytes compared).
[[nodiscard]] bool signature_matches(const SigningKey& key, const FrameView& frame);

// Why a frame failed the signing check of a receiver that requires signatures.
enum class SigningRefusal : std::uint8_t {
  NotMavlink,     // not a MAVLink 2 frame (split_frame refused it)
  Unsigned,       // no signature
  BadSignature,   // signed with another key (or altered)
  Replayed,       // timestamp not after the last one of its stream (sysid, compid, link id)
  Stale,          // a new stream whose timestamp is more than a minute behind the newest seen
  TooManyStreams, // more streams than the receiver tracks
};
inline constexpr std::size_t kSigningRefusalCount = 6;
[[nodiscard]] std::string_view to_string(SigningRefusal refusal);

// The receiving side of message signing (spec "Accepting signed packets", as the reference C library's
// mavlink_signature_check): the signature must match, and the timestamp must be after the last one of its
// stream — a stream is (sysid, compid, link id) — and, for a stream not seen before, no more than one minute
// behind the newest timestamp seen. State changes only for an accepted frame.
class SignatureChecker {
 public:
  static constexpr std::size_t kMaxStreams = 16;
  static constexpr std::uint64_t kNewStreamWindow = 6'000'000;  // [10 µs] = 60 s
  explicit SignatureChecker(SigningKey key) : key_(key) {}
  [[nodiscard]] Result<void, SigningRefusal> check(std::span<const std::byte> datagram);

 private:
  struct Stream {
    std::uint8_t sysid = 0;
    std::uint8_t compid = 0;
    std::uint8_t link_id = 0;
    std::uint64_t last = 0;
  };
  SigningKey key_;
  std::array<Stream, kMaxStreams> streams_{};
  std::size_t stream_count_ = 0;
  std::uint64_t newest_ = 0;
};

}  // namespace rejuv::mavlink
