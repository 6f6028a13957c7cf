// The messages between image_driver (the kernel's part) and image_service: one byte of kind, a body of at most
// 64 bytes, at most one fd. The kinds are listed at the top of image_service.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cstring>

#include "rejuv/sys/channel.hpp"

namespace rejuv::bench_image {

struct Message {
  char kind = 0;
  std::array<std::byte, 64> body{};
  std::size_t body_size = 0;
  sys::UniqueFd fd;
  template <typename T>
  [[nodiscard]] T at(std::size_t offset) const {
    T v{};
    std::memcpy(&v, body.data() + offset, sizeof(T));
    return v;
  }
};

// One message (waits as the socket does); false when the socket failed, closed or sent an empty datagram.
[[nodiscard]] inline bool receive_message(const sys::SeqPacket& from, Message& m) {
  std::array<std::byte, 1 + sizeof(Message::body)> buf{};
  auto got = from.receive(buf, 1);
  if (!got || got->closed || got->size == 0) return false;
  m.kind = static_cast<char>(buf[0]);
  m.body_size = got->size - 1;
  std::memcpy(m.body.data(), buf.data() + 1, m.body_size);
  m.fd = got->fds.empty() ? sys::UniqueFd() : std::move(got->fds.front());
  return true;
}

// `kind`, then `parts` back to back as the body, with `fd` unless it is -1.
template <typename... T>
[[nodiscard]] bool send_message(const sys::SeqPacket& to, char kind, int fd, const T&... parts) {
  static_assert((sizeof(T) + ... + 0) <= sizeof(Message::body));
  std::array<std::byte, 1 + sizeof(Message::body)> buf{};
  buf[0] = static_cast<std::byte>(kind);
  std::size_t at = 1;
  ((std::memcpy(buf.data() + at, &parts, sizeof(parts)), at += sizeof(parts)), ...);
  const std::span<const std::byte> bytes(buf.data(), at);
  return (fd >= 0 ? to.send(bytes, std::span(&fd, 1)) : to.send(bytes)).has_value();
}

}  // namespace rejuv::bench_image
