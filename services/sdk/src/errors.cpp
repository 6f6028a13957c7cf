// The SDK's errors as text (SdkError, Error), the helpers that make them, and a Reply's error field as an
// Error (docs/protocol.md "Requests": 0 ok, 1 + cap::CapError for a denial, an operation error ≥ 100).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>

#include "rejuv/channel/codes.hpp"
#include "service_impl.hpp"

namespace rejuv::sdk {

std::string_view to_string(SdkError error) {
  switch (error) {
    case SdkError::NotAService: return "not a service";
    case SdkError::ChannelIo: return "channel i/o";
    case SdkError::ChannelClosed: return "channel closed";
    case SdkError::Protocol: return "protocol violation";
    case SdkError::VersionMismatch: return "protocol version mismatch";
    case SdkError::NoSuchObject: return "no such object";
    case SdkError::WrongObjectKind: return "wrong object kind";
    case SdkError::TypeMismatch: return "type mismatch";
    case SdkError::NeverGranted: return "never granted";
    case SdkError::NotHeldInMode: return "not held in this mode";
    case SdkError::AlreadySubscribed: return "already subscribed";
    case SdkError::TooManyTimers: return "too many timers";
    case SdkError::NoSuchTimer: return "no such timer";
    case SdkError::BadArgument: return "bad argument";
    case SdkError::Denied: return "denied";
    case SdkError::OperationFailed: return "operation failed";
    case SdkError::RolledBack: return "rolled back (this is a restored image)";
    case SdkError::Resources: return "out of resources";
  }
  return "?";
}

std::string Error::to_string() const {
  std::string out(sdk::to_string(code));
  if (cap_error) {
    out += ": ";
    out += cap::to_string(*cap_error);
  } else if (wire_error != 0) {
    out += ": ";
    out += wire::to_string(static_cast<wire::OpError>(wire_error));
  }
  if (!detail.empty()) {
    out += " (" + detail + ")";
  }
  return out;
}

int report_connect_failure(const Error& error) {
  const char* name = std::getenv("REJUV_SERVICE");
  std::fprintf(stderr, "[%s] cannot connect to the kernel: %s\n", name != nullptr ? name : "?",
               error.to_string().c_str());
  return 2;
}

std::unexpected<Error> error(SdkError code, std::string detail) {
  return std::unexpected(Error{.code = code, .cap_error = std::nullopt, .wire_error = 0, .detail = std::move(detail)});
}

std::unexpected<Error> io_error(const sys::SysError& e) { return error(SdkError::ChannelIo, e.to_string()); }

std::unexpected<Error> reply_error(std::int32_t wire_error, std::string detail) {
  Error out{.code = SdkError::Protocol, .cap_error = std::nullopt, .wire_error = wire_error, .detail = std::move(detail)};
  switch (channel::reply_kind(wire_error)) {
    case channel::ReplyKind::Denied:
      out.code = SdkError::Denied;
      out.cap_error = channel::denial_of(wire_error);
      break;
    case channel::ReplyKind::OperationFailed: out.code = SdkError::OperationFailed; break;
    case channel::ReplyKind::Ok:  // not an error: a caller that asks has broken the protocol's rule
    case channel::ReplyKind::Unknown: break;
  }
  return std::unexpected(std::move(out));
}

}  // namespace rejuv::sdk
