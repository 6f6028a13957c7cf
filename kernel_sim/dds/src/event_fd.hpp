// A non-blocking eventfd: the one OS object of the DDS bridge (the readiness signal from Cyclone's listener
// thread to the kernel's event loop). Private to rejuv_dds; kept in this tiny file, apart from the DDS code,
// because kernel_sim/sys (the system-call layer) does not own an eventfd yet.
#pragma once

#include "rejuv/sys/fd.hpp"

namespace rejuv::dds::detail {

class EventFd {
 public:
  [[nodiscard]] static sys::SysResult<EventFd> create();
  // Makes the fd readable. Async-signal- and thread-safe: one write(2), nothing else.
  void signal() const noexcept;
  // Makes it unreadable again (reads and discards the counter).
  void drain() const noexcept;
  [[nodiscard]] int fd() const { return fd_.get(); }

 private:
  explicit EventFd(sys::UniqueFd fd) : fd_(std::move(fd)) {}
  sys::UniqueFd fd_;
};

}  // namespace rejuv::dds::detail
