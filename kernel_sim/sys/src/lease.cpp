#include "rejuv/sys/lease.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <string>

namespace rejuv::sys {

SysResult<Lease> lease_slot(const char* lock_file, std::uint32_t first, std::uint32_t count, std::uint32_t hint) {
  // Close-on-exec: a child (`rejuv run` of a sweep) is told its slot, it does not hold the lease.
  UniqueFd fd(::open(lock_file, O_RDWR | O_CREAT | O_CLOEXEC, 0666));
  if (!fd) return last_error("open(" + std::string(lock_file) + ")");
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::uint32_t slot = (hint + i) % count + first;
    struct flock range{};
    range.l_type = F_WRLCK;
    range.l_whence = SEEK_SET;
    range.l_start = static_cast<off_t>(slot);
    range.l_len = 1;
    if (::fcntl(fd.get(), F_OFD_SETLK, &range) == 0) return Lease(std::move(fd), slot);
    if (errno != EAGAIN && errno != EACCES) return last_error("fcntl(F_OFD_SETLK)");
  }
  errno = EBUSY;
  return last_error("lease_slot(" + std::string(lock_file) + ")");
}

}  // namespace rejuv::sys
