// One end of a private kernel ↔ service channel: a Unix SOCK_SEQPACKET socket (docs/design.md §2). Message
// boundaries are kept, so a frame is one send and one receive; fds travel with SCM_RIGHTS.
#pragma once

#include <cstddef>
#include <span>
#include <utility>
#include <vector>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

enum class Blocking : std::uint8_t { Yes, No };
// receive_batch: return at once (EAGAIN when nothing waits), or, on a blocking fd, wait for the first frame.
enum class Wait : std::uint8_t { No, ForOne };

// receive_batch: frames per recvmmsg at most.
inline constexpr std::size_t kMaxReceiveBatch = 16;

// What one receive produced.
struct Received {
  std::size_t size = 0;            // bytes written into the buffer
  bool truncated = false;          // the datagram was longer than the buffer (rest discarded)
  bool closed = false;             // the peer closed its end (size is 0)
  bool fds_truncated = false;      // more fds arrived than fit: the extra ones were closed by the kernel
  std::vector<UniqueFd> fds;       // fds that came with the frame (close-on-exec); the caller owns them
};

class SeqPacket {
 public:
  SeqPacket() = default;
  explicit SeqPacket(UniqueFd fd) : fd_(std::move(fd)) {}

  // A connected pair, close-on-exec; Blocking::No makes both ends non-blocking.
  [[nodiscard]] static SysResult<std::pair<SeqPacket, SeqPacket>> pair(Blocking blocking = Blocking::Yes);

  // Sends one datagram (and fds), never waiting, also on a blocking fd (a service's channel blocks for its
  // reads only): a full channel is EAGAIN as an error value. Never raises SIGPIPE: a closed peer is EPIPE.
  [[nodiscard]] SysResult<void> send(std::span<const std::byte> frame, std::span<const int> fds = {}) const;
  // Receives one datagram into buf (not empty); at most max_fds fds are accepted. Waits as the fd says; EAGAIN
  // on a non-blocking end is an error value with error == EAGAIN.
  [[nodiscard]] SysResult<Received> receive(std::span<std::byte> buf, std::size_t max_fds = 0) const;
  // Up to kMaxReceiveBatch frames in one recvmmsg: `slots` is cut into slots of `slot_bytes`; frame i lands
  // in slot i and is described by out[i] as receive(slot i, max_fds) would. Returns how many (≥ 1), ending
  // at an end-of-stream entry (closed); EAGAIN as an error value when no frame is waiting and `wait` is No
  // (or the fd is non-blocking). Wait::ForOne on a blocking fd sleeps until the first frame, then takes
  // what else is there (MSG_WAITFORONE): the wait is the read. One system call for a burst instead of one
  // per frame.
  [[nodiscard]] SysResult<std::size_t> receive_batch(std::span<std::byte> slots, std::size_t slot_bytes,
                                                     std::span<Received> out, std::size_t max_fds = 0,
                                                     Wait wait = Wait::No) const;
  // receive() without allocating, for a process that must not touch its heap (a frozen service image,
  // services/sdk memory_image.hpp): the fds go into `fds` (`fd_count` of them; more are closed). Returns the
  // datagram's size; 0: the peer closed.
  [[nodiscard]] SysResult<std::size_t> receive_into(std::span<std::byte> buf, std::span<int> fds,
                                                    std::size_t& fd_count) const;

  [[nodiscard]] int fd() const { return fd_.get(); }
  [[nodiscard]] bool valid() const { return fd_.valid(); }
  [[nodiscard]] UniqueFd take_fd() { return std::move(fd_); }
  void close() { fd_.reset(); }

 private:
  UniqueFd fd_;
};

}  // namespace rejuv::sys
