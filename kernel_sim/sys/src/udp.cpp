#include "rejuv/sys/udp.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstring>

namespace rejuv::sys {

namespace {
sockaddr_in to_sockaddr(UdpAddress a) {
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(a.port);
  sa.sin_addr.s_addr = htonl(a.ip);
  return sa;
}
UdpAddress from_sockaddr(const sockaddr_in& sa) {
  return UdpAddress{.ip = ntohl(sa.sin_addr.s_addr), .port = ntohs(sa.sin_port)};
}
}  // namespace

Result<UdpAddress, std::string> UdpAddress::parse(std::string_view ip, std::uint16_t port) {
  const std::string text(ip);
  in_addr addr{};
  if (::inet_pton(AF_INET, text.c_str(), &addr) != 1) {
    return fail("'" + text + "' is not an IPv4 address (dotted quad, e.g. 127.0.0.1)");
  }
  return UdpAddress{.ip = ntohl(addr.s_addr), .port = port};
}

std::string UdpAddress::to_string() const {
  return std::to_string((ip >> 24U) & 0xFFU) + "." + std::to_string((ip >> 16U) & 0xFFU) + "." +
         std::to_string((ip >> 8U) & 0xFFU) + "." + std::to_string(ip & 0xFFU) + ":" + std::to_string(port);
}

SysResult<UdpSocket> UdpSocket::bind(UdpAddress local, Blocking blocking) {
  const int type = SOCK_DGRAM | SOCK_CLOEXEC | (blocking == Blocking::No ? SOCK_NONBLOCK : 0);
  UniqueFd fd(::socket(AF_INET, type, 0));
  if (!fd) return last_error("socket(AF_INET, SOCK_DGRAM)");
  const sockaddr_in sa = to_sockaddr(local);
  if (::bind(fd.get(), reinterpret_cast<const sockaddr*>(&sa), sizeof sa) != 0) return last_error("bind");
  return UdpSocket(std::move(fd));
}

SysResult<UdpAddress> UdpSocket::local_address() const {
  sockaddr_in sa{};
  socklen_t len = sizeof sa;
  if (::getsockname(fd_.get(), reinterpret_cast<sockaddr*>(&sa), &len) != 0) return last_error("getsockname");
  return from_sockaddr(sa);
}

SysResult<void> UdpSocket::send_to(std::span<const std::byte> datagram, UdpAddress to) const {
  const sockaddr_in sa = to_sockaddr(to);
  ssize_t n = -1;
  do {
    n = ::sendto(fd_.get(), datagram.data(), datagram.size(), MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&sa),
                 sizeof sa);
  } while (n < 0 && errno == EINTR);
  if (n < 0) return last_error("sendto");
  if (static_cast<std::size_t>(n) != datagram.size()) return std::unexpected(SysError{"sendto", EMSGSIZE});
  return {};
}

SysResult<UdpReceived> UdpSocket::receive(std::span<std::byte> buf) const {
  sockaddr_in sa{};
  socklen_t len = sizeof sa;
  ssize_t n = -1;
  do {
    // MSG_TRUNC: the return value is the datagram's real length even when it did not fit (udp(7)).
    n = ::recvfrom(fd_.get(), buf.data(), buf.size(), MSG_TRUNC, reinterpret_cast<sockaddr*>(&sa), &len);
  } while (n < 0 && errno == EINTR);
  if (n < 0) return last_error("recvfrom");
  const auto real = static_cast<std::size_t>(n);
  return UdpReceived{.size = std::min(real, buf.size()),
                     .datagram_size = real,
                     .truncated = real > buf.size(),
                     .from = from_sockaddr(sa)};
}

}  // namespace rejuv::sys
