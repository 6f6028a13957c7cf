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
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <ratio>
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

// A frame's checksum: CRC-16/MCRF4XX of its header and payload without the STX, then the message's CRC_EXTRA.
[[nodiscard]] constexpr std::uint16_t frame_checksum(std::span<const std::byte> header_and_payload, std::uint8_t crc_extra) {
  Crc16 crc;
  crc.add(header_and_payload.subspan(1));
  crc.add(crc_extra);
  return crc.value();
}

// The 32-byte secret key of message signing. Only the kernel's network gate and the ground station hold it.
struct SigningKey {
  std::array<std::uint8_t, 32> bytes{};
  // 64 hex digits (either case), nothing else.
  [[nodiscard]] static Result<SigningKey, std::string> from_hex(std::string_view hex);
  friend bool operator==(const SigningKey&, const SigningKey&) = default;
};

// The signing clock (MAVLink spec "Message Signing", "Timestamp Handling"): UTC since 2015-01-01 00:00:00 in
// 10 µs ticks, 48 bits on the wire. now() reads the wall clock (CLOCK_REALTIME, std::chrono::system_clock): a
// ground station stamps its frames from its own wall clock, so the receiver compares them with real time, also
// when the flight itself runs in lockstep.
struct SigningClock {
  using rep = std::uint64_t;
  using period = std::ratio<1, 100'000>;
  using duration = std::chrono::duration<rep, period>;
  using time_point = std::chrono::time_point<SigningClock>;
  static constexpr bool is_steady = false;
  [[nodiscard]] static time_point now();
  // A Unix time as a signing time (the epoch itself for any time before it).
  [[nodiscard]] static time_point from_sys(std::chrono::system_clock::time_point t);
};
using SigningTime = SigningClock::time_point;
inline constexpr std::uint64_t kUnixSecondsAtSigningEpoch = 1420070400;  // 2015-01-01 00:00:00 UTC
inline constexpr std::uint64_t kMaxSigningTicks = (std::uint64_t{1} << 48U) - 1;  // the wire's 48 bits

// The signature block of a signed frame.
struct Signature {
  std::uint8_t link_id = 0;
  SigningTime timestamp{};  // 48 bits on the wire
  std::array<std::uint8_t, 6> value{};
  friend bool operator==(const Signature&, const Signature&) = default;
};

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
  Replayed,       // timestamp not after the last accepted one of its stream (sysid, compid, link id)
  Stale,          // timestamp more than a minute behind the local signing time (a recording, an old capture)
  TooManyStreams, // a new stream while the receiver tracks as many live streams as it keeps
};
inline constexpr std::size_t kSigningRefusalCount = 6;
[[nodiscard]] std::string_view to_string(SigningRefusal refusal);

// The receiving side of message signing (spec "Message Signing": "Accepting Signed Packets", "Timestamp
// Handling"). A signed frame is accepted when
//   - its signature is the key's;
//   - its timestamp is no more than one minute behind the local signing time: the newest of the local clock
//     (the `local_clock` each check is given; the gate's is the wall clock) and the timestamps accepted so far.
//     The local time starts at the clock, never at 0, so a frame recorded long ago is refused from the first;
//   - its timestamp is strictly after the last accepted one of its stream (sysid, compid, link id; the spec
//     says "must monotonically increase", and the reference C library refuses an equal one too). A stream not
//     seen before has only the one-minute bound.
// At most kMaxStreams streams are kept. A new stream takes a free entry, else the entry of a stream whose last
// timestamp is itself more than a minute behind the local time: everything that stream could replay is stale
// already, so forgetting it loses no protection (the local time never goes back). With every entry live the
// new stream is refused (TooManyStreams); the streams kept are not disturbed. Only a key holder can open a
// stream (the signature is checked first), so the table is no memory an outsider can grow.
// Nothing changes for a refused frame.
class SignatureChecker {
 public:
  static constexpr std::size_t kMaxStreams = 16;
  static constexpr SigningClock::duration kWindow{6'000'000};  // one minute
  static_assert(kWindow == std::chrono::minutes{1});
  explicit SignatureChecker(SigningKey key) : key_(key) {}
  [[nodiscard]] Result<void, SigningRefusal> check(std::span<const std::byte> datagram, SigningTime local_clock);
  // The local signing time as of the last accepted frame (the spec's "local system timestamp").
  [[nodiscard]] SigningTime local_time() const { return local_; }
  [[nodiscard]] std::size_t stream_count() const { return stream_count_; }
  [[nodiscard]] const SigningKey& key() const { return key_; }

 private:
  struct Stream {
    std::uint8_t sysid = 0;
    std::uint8_t compid = 0;
    std::uint8_t link_id = 0;
    SigningTime last{};
  };
  SigningKey key_;
  std::array<Stream, kMaxStreams> streams_{};
  std::size_t stream_count_ = 0;
  SigningTime local_{};
};

}  // namespace rejuv::mavlink
