#include "rejuv/sys/channel.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

namespace rejuv::sys {

namespace {
constexpr std::size_t kMaxFdsPerFrame = 4;
}

SysResult<std::pair<SeqPacket, SeqPacket>> SeqPacket::pair(Blocking blocking) {
  std::array<int, 2> fds{-1, -1};
  const int flags = SOCK_SEQPACKET | SOCK_CLOEXEC | (blocking == Blocking::No ? SOCK_NONBLOCK : 0);
  if (::socketpair(AF_UNIX, flags, 0, fds.data()) != 0) {
    return last_error("socketpair");
  }
  return std::pair{SeqPacket(UniqueFd(fds[0])), SeqPacket(UniqueFd(fds[1]))};
}

SysResult<void> SeqPacket::send(std::span<const std::byte> frame, std::span<const int> fds) const {
  if (fds.size() > kMaxFdsPerFrame) {
    return std::unexpected(SysError{"sendmsg", E2BIG});
  }
  iovec iov{const_cast<std::byte*>(frame.data()), frame.size()};  // NOLINT: sendmsg does not write
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(int) * kMaxFdsPerFrame)> control{};
  if (!fds.empty()) {
    msg.msg_control = control.data();
    msg.msg_controllen = CMSG_SPACE(sizeof(int) * fds.size());
    cmsghdr* cmsg = CMSG_FIRSTHDR(&msg);
    cmsg->cmsg_level = SOL_SOCKET;
    cmsg->cmsg_type = SCM_RIGHTS;
    cmsg->cmsg_len = CMSG_LEN(sizeof(int) * fds.size());
    std::memcpy(CMSG_DATA(cmsg), fds.data(), sizeof(int) * fds.size());
  }
  ssize_t n = -1;
  do {
    n = ::sendmsg(fd_.get(), &msg, MSG_NOSIGNAL | MSG_DONTWAIT);
  } while (n < 0 && errno == EINTR);
  if (n < 0) {
    return last_error("sendmsg");
  }
  if (static_cast<std::size_t>(n) != frame.size()) {
    return std::unexpected(SysError{"sendmsg", EMSGSIZE});
  }
  return {};
}

namespace {

// Calls take(fd) for every fd a received message carried (SCM_RIGHTS); the callee owns it.
template <class F>
void for_each_fd(msghdr& msg, F take) {
  for (cmsghdr* cmsg = CMSG_FIRSTHDR(&msg); cmsg != nullptr; cmsg = CMSG_NXTHDR(&msg, cmsg)) {
    if (cmsg->cmsg_level != SOL_SOCKET || cmsg->cmsg_type != SCM_RIGHTS) {
      continue;
    }
    const std::size_t count = (cmsg->cmsg_len - CMSG_LEN(0)) / sizeof(int);
    for (std::size_t i = 0; i < count; ++i) {
      int fd = -1;
      std::memcpy(&fd, CMSG_DATA(cmsg) + i * sizeof(int), sizeof(int));
      take(fd);
    }
  }
}

// What recvmmsg reported for one datagram: its size, flags and the fds it carried (beyond max_fds:
// closed here and flagged, so that a hostile peer's fds are never leaked).
Received describe(msghdr& msg, std::size_t n, std::size_t buffer_size, std::size_t max_fds) {
  Received r;
  r.size = n;
  r.truncated = (msg.msg_flags & MSG_TRUNC) != 0;
  r.fds_truncated = (msg.msg_flags & MSG_CTRUNC) != 0;
  r.closed = n == 0 && buffer_size > 0 && !r.truncated;
  for_each_fd(msg, [&](int fd) {
    UniqueFd owned(fd);
    if (r.fds.size() < max_fds) {
      r.fds.push_back(std::move(owned));
    } else {
      r.fds_truncated = true;  // unexpected fd: closed right here by UniqueFd
    }
  });
  return r;
}

using Control = std::array<char, CMSG_SPACE(sizeof(int) * kMaxFdsPerFrame)>;

}  // namespace

SysResult<Received> SeqPacket::receive(std::span<std::byte> buf, std::size_t max_fds) const {
  REJUV_ASSERT(!buf.empty(), "receive into an empty buffer");
  // A batch of one: MSG_WAITFORONE only stops waiting after the first datagram, so this waits exactly as
  // recvmsg would on this fd (blocking or not).
  std::array<Received, 1> out{};
  if (auto n = receive_batch(buf, buf.size(), out, max_fds, Wait::ForOne); !n) return std::unexpected(n.error());
  return std::move(out[0]);
}

SysResult<std::size_t> SeqPacket::receive_batch(std::span<std::byte> slots, std::size_t slot_bytes,
                                                std::span<Received> out, std::size_t max_fds, Wait wait) const {
  const std::size_t n = slot_bytes == 0 ? 0 : std::min({slots.size() / slot_bytes, out.size(), kMaxReceiveBatch});
  if (n == 0) return 0;
  std::array<iovec, kMaxReceiveBatch> iov{};
  std::array<mmsghdr, kMaxReceiveBatch> msgs{};
  alignas(cmsghdr) std::array<Control, kMaxReceiveBatch> control{};
  for (std::size_t i = 0; i < n; ++i) {
    iov[i] = iovec{slots.data() + i * slot_bytes, slot_bytes};
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
    msgs[i].msg_hdr.msg_control = control[i].data();
    msgs[i].msg_hdr.msg_controllen = control[i].size();
  }
  int got = -1;
  do {
    const int when = wait == Wait::ForOne ? MSG_WAITFORONE : MSG_DONTWAIT;
    got = ::recvmmsg(fd_.get(), msgs.data(), static_cast<unsigned>(n), when | MSG_CMSG_CLOEXEC, nullptr);
  } while (got < 0 && errno == EINTR);
  if (got < 0) {
    return last_error("recvmmsg");
  }
  for (std::size_t i = 0; i < static_cast<std::size_t>(got); ++i) {
    out[i] = describe(msgs[i].msg_hdr, msgs[i].msg_len, slot_bytes, max_fds);
    if (out[i].closed) return i + 1;  // end of stream: what follows it is more of the same
  }
  return static_cast<std::size_t>(got);
}

SysResult<std::size_t> SeqPacket::receive_into(std::span<std::byte> buf, std::span<int> fds,
                                               std::size_t& fd_count) const {
  iovec iov{buf.data(), buf.size()};
  alignas(cmsghdr) Control control{};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control.data();
  msg.msg_controllen = control.size();
  ssize_t n = -1;
  do {
    n = ::recvmsg(fd_.get(), &msg, MSG_CMSG_CLOEXEC);
  } while (n < 0 && errno == EINTR);
  fd_count = 0;
  if (n < 0) return last_error("recvmsg");
  for_each_fd(msg, [&](int fd) {
    if (fd_count < fds.size()) {
      fds[fd_count++] = fd;
    } else {
      ::close(fd);
    }
  });
  return static_cast<std::size_t>(n);
}

}  // namespace rejuv::sys
