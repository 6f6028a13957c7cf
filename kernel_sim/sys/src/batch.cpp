#include "rejuv/sys/batch.hpp"

#include <sys/socket.h>

#include <array>
#include <cerrno>

namespace rejuv::sys {

SysResult<std::size_t> send_batch(int fd, std::span<const std::span<const std::byte>> frames) {
  std::array<iovec, kMaxBatchFrames> iov{};
  std::array<mmsghdr, kMaxBatchFrames> msgs{};
  const std::size_t n = std::min(frames.size(), kMaxBatchFrames);
  for (std::size_t i = 0; i < n; ++i) {
    iov[i] = iovec{const_cast<std::byte*>(frames[i].data()), frames[i].size()};  // NOLINT: sendmmsg does not write
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
  }
  int sent = -1;
  do {
    sent = ::sendmmsg(fd, msgs.data(), static_cast<unsigned>(n), MSG_NOSIGNAL | MSG_DONTWAIT);
  } while (sent < 0 && errno == EINTR);
  if (sent < 0) return last_error("sendmmsg");
  return static_cast<std::size_t>(sent);
}

}  // namespace rejuv::sys
