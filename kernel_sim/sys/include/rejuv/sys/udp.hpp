// A UDP socket (IPv4) for the kernel's network gate (docs/design.md §2: the kernel owns the external link's socket;
// services have none, seccomp denies them) and for the `rejuv gcs` tool on the other side of the link.
// Thin RAII over socket/bind/sendto/recvfrom; everything above it is typed C++.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// An IPv4 address and port, in host byte order.
struct UdpAddress {
  std::uint32_t ip = 0x7F00'0001U;  // 127.0.0.1
  std::uint16_t port = 0;           // 0 when binding: an ephemeral port
  [[nodiscard]] static UdpAddress loopback(std::uint16_t port) { return UdpAddress{.ip = 0x7F00'0001U, .port = port}; }
  // Dotted-quad text ("127.0.0.1"); nullopt-like error value when it is not one.
  [[nodiscard]] static Result<UdpAddress, std::string> parse(std::string_view ip, std::uint16_t port);
  [[nodiscard]] std::string to_string() const;  // "127.0.0.1:14550"
  friend bool operator==(const UdpAddress&, const UdpAddress&) = default;
};

// What one receive produced.
struct UdpReceived {
  std::size_t size = 0;           // bytes written into the buffer
  std::size_t datagram_size = 0;  // the datagram's real length (larger than size when truncated)
  bool truncated = false;         // the datagram did not fit in the buffer (the rest is discarded)
  UdpAddress from{};
};

class UdpSocket {
 public:
  UdpSocket() = default;
  // A datagram socket bound to `local` (close-on-exec; Blocking::No makes it non-blocking).
  [[nodiscard]] static SysResult<UdpSocket> bind(UdpAddress local, Blocking blocking = Blocking::No);

  // The address the socket is bound to (the real port after binding port 0).
  [[nodiscard]] SysResult<UdpAddress> local_address() const;
  // Sends one datagram. A datagram that is not sent whole is EMSGSIZE.
  [[nodiscard]] SysResult<void> send_to(std::span<const std::byte> datagram, UdpAddress to) const;
  // Receives one datagram into buf. EAGAIN on a non-blocking socket with nothing queued is an error value
  // with error == EAGAIN.
  [[nodiscard]] SysResult<UdpReceived> receive(std::span<std::byte> buf) const;

  [[nodiscard]] int fd() const { return fd_.get(); }
  [[nodiscard]] bool valid() const { return fd_.valid(); }
  void close() { fd_.reset(); }

 private:
  explicit UdpSocket(UniqueFd fd) : fd_(std::move(fd)) {}
  UniqueFd fd_;
};

}  // namespace rejuv::sys
