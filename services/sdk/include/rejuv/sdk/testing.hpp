// The raw surface of the SDK, for security tests, fuzzing and the attack library only: what any code inside a
// service can do anyway (frames written on fd 3, an Invoke on any slot, a publication whatever the mode), kept
// out of the service author's API (service.hpp). The kernel is the authority for all of it: each call here is
// one frame the kernel checks like any other.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "rejuv/sdk/service.hpp"

namespace rejuv::sdk::testing {

class RawAccess {
 public:
  // Sends everything queued, then `frame`, at once.
  static SdkResult<void> send_raw(Service& svc, std::span<const std::byte> frame);
  // Invoke `op` on the cap of `object` (or on `slot`: a forged or empty slot is the kernel's to refuse) with the
  // wire's raw arguments (docs/protocol.md "Invoke"); blocks for the Reply.
  static SdkResult<InvokeReply> invoke(Service& svc, std::string_view object, cap::Operation op,
                                       std::uint64_t arg0 = 0, std::uint64_t arg1 = 0,
                                       std::span<const std::byte> data = {}, std::span<std::byte> out = {});
  static SdkResult<InvokeReply> invoke_slot(Service& svc, Slot slot, cap::Operation op, std::uint64_t arg0 = 0,
                                            std::uint64_t arg1 = 0, std::span<const std::byte> data = {},
                                            std::span<std::byte> out = {});
  // Publishes on `cap` (which may be forged) regardless of the current mode.
  static SdkResult<void> publish_unchecked(Service& svc, const CapInfo& cap, std::span<const std::byte> payload);
  template <class T>
  static SdkResult<void> publish_unchecked(const Publisher<T>& publisher, const T& message) {
    return publish_unchecked(*publisher.service_, *publisher.cap_, std::as_bytes(std::span(&message, 1)));
  }
};

inline SdkResult<void> send_raw(Service& svc, std::span<const std::byte> frame) {
  return RawAccess::send_raw(svc, frame);
}
inline SdkResult<InvokeReply> invoke(Service& svc, std::string_view object, cap::Operation op, std::uint64_t arg0 = 0,
                                     std::uint64_t arg1 = 0, std::span<const std::byte> data = {},
                                     std::span<std::byte> out = {}) {
  return RawAccess::invoke(svc, object, op, arg0, arg1, data, out);
}
inline SdkResult<InvokeReply> invoke_slot(Service& svc, Slot slot, cap::Operation op, std::uint64_t arg0 = 0,
                                          std::uint64_t arg1 = 0, std::span<const std::byte> data = {},
                                          std::span<std::byte> out = {}) {
  return RawAccess::invoke_slot(svc, slot, op, arg0, arg1, data, out);
}
inline SdkResult<void> publish_unchecked(Service& svc, const CapInfo& cap, std::span<const std::byte> payload) {
  return RawAccess::publish_unchecked(svc, cap, payload);
}
template <class T>
SdkResult<void> publish_unchecked(const Publisher<T>& publisher, const T& message) {
  return RawAccess::publish_unchecked(publisher, message);
}

}  // namespace rejuv::sdk::testing
