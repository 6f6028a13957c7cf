#include "event_fd.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>

namespace rejuv::dds::detail {

sys::SysResult<EventFd> EventFd::create() {
  const int fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (fd < 0) {
    return sys::last_error("eventfd");
  }
  return EventFd(sys::UniqueFd(fd));
}

void EventFd::signal() const noexcept {
  const std::uint64_t one = 1;
  // Can only fail with EAGAIN when the counter is about to overflow (2^64 − 2 signals unread): then it is
  // readable anyway, which is all a signal means.
  [[maybe_unused]] const ssize_t n = ::write(fd_.get(), &one, sizeof one);
}

void EventFd::drain() const noexcept {
  std::uint64_t count = 0;
  // EAGAIN when already unreadable: nothing to do.
  [[maybe_unused]] const ssize_t n = ::read(fd_.get(), &count, sizeof count);
}

}  // namespace rejuv::dds::detail
