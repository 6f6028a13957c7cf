// Several frames on a SOCK_SEQPACKET channel in one system call (sendmmsg): a service's publications and
// its Idle leave together, so the kernel wakes once for them instead of once per frame.
#pragma once

#include <cstddef>
#include <span>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

inline constexpr std::size_t kMaxBatchFrames = 64;

// Sends frames[0..] in order, each as one datagram, without fds. Returns how many were sent (≥ 1); EAGAIN
// (as an error value) when the channel is full before the first one, also on a blocking fd (MSG_DONTWAIT:
// a service's channel is blocking for its reads, never for its sends). Never raises SIGPIPE.
[[nodiscard]] SysResult<std::size_t> send_batch(int fd, std::span<const std::span<const std::byte>> frames);

}  // namespace rejuv::sys
