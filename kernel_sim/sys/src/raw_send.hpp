// One datagram of `size` bytes and at most one fd (SCM_RIGHTS; none when fd < 0), sent with raw system calls
// only: async-signal-safe, for a child forked from a process with threads (a spawned service before exec,
// process.cpp; the pagemap agent, pagemap_agent.cpp). Never raises SIGPIPE; the result is not looked at (the
// peer sees a missing answer).
#pragma once

#include <sys/socket.h>

#include <array>
#include <cstddef>
#include <cstring>

namespace rejuv::sys::detail {

inline void send_raw_with_fd(int socket_fd, const void* data, std::size_t size, int fd) {
  iovec iov{const_cast<void*>(data), size};  // NOLINT: sendmsg's signature
  alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(int))> control{};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  if (fd >= 0) {
    msg.msg_control = control.data();
    msg.msg_controllen = control.size();
    cmsghdr* c = CMSG_FIRSTHDR(&msg);
    c->cmsg_level = SOL_SOCKET;
    c->cmsg_type = SCM_RIGHTS;
    c->cmsg_len = CMSG_LEN(sizeof(int));
    std::memcpy(CMSG_DATA(c), &fd, sizeof(int));
  }
  (void)!::sendmsg(socket_fd, &msg, MSG_NOSIGNAL);
}

}  // namespace rejuv::sys::detail
