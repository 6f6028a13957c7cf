// The codes both ends of a channel put in the fixed fields of a payload (docs/protocol.md "Requests"): the
// error field of a Reply and the rights bits of a BootCap or of a Copy/Mint Invoke. One definition for the
// kernel, which writes them, and the SDK, which reads them (docs/conventions.md "One protocol, one codec").
#pragma once

#include <cstdint>
#include <optional>

#include "rejuv/cap/capability.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::channel {

// ---- ReplyHeader::error: 0 ok, 1 + cap::CapError for a denial, an operation error ≥ wire::kFirstOpError ----

inline constexpr std::int32_t kReplyOk = 0;
[[nodiscard]] constexpr std::int32_t denial_code(cap::CapError e) { return 1 + static_cast<std::int32_t>(e); }
[[nodiscard]] constexpr std::int32_t op_code(wire::OpError e) { return static_cast<std::int32_t>(e); }

// What a Reply's error field says, as its reader sorts it.
enum class ReplyKind : std::uint8_t {
  Ok,               // 0
  Denied,           // the capability check refused the request: denial_of() names the CapError
  OperationFailed,  // the cap was valid but the operation could not be carried out (a wire::OpError, or a newer one)
  Unknown,          // a code no kernel sends (negative, or between the denials and the operation errors)
};
[[nodiscard]] constexpr ReplyKind reply_kind(std::int32_t code) {
  if (code == kReplyOk) return ReplyKind::Ok;
  if (code >= 1 && code <= static_cast<std::int32_t>(cap::kCapErrorCount)) return ReplyKind::Denied;
  if (code >= wire::kFirstOpError) return ReplyKind::OperationFailed;
  return ReplyKind::Unknown;
}
// The CapError of a denial code; nullopt for any other code.
[[nodiscard]] constexpr std::optional<cap::CapError> denial_of(std::int32_t code) {
  if (reply_kind(code) != ReplyKind::Denied) return std::nullopt;
  return static_cast<cap::CapError>(code - 1);
}

// ---- rights on the wire: the Right bits of rejuv::Rights, in one byte (BootCap::rights_by_mode, the low byte
// of a Copy/Mint InvokeHeader::arg1). Bits that name no right are ignored. ----

[[nodiscard]] constexpr std::uint8_t rights_bits(Rights rights) { return rights.bits(); }
[[nodiscard]] constexpr Rights rights_from_bits(std::uint64_t bits) {
  Rights r = Rights::none();
  for (const Right x : {Right::Read, Right::Write, Right::Grant}) {
    if ((bits & static_cast<std::uint8_t>(x)) != 0) r = r | x;
  }
  return r;
}

}  // namespace rejuv::channel
