#include "rejuv/sys/lease.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <string>

namespace rejuv::sys {

SysResult<Lease> lease_slot(const char* lock_file, std::uint32_t first, std::uint32_t count, std::uint32_t hint) {
  // Close-on-exec: a child (`rejuv run` of a sweep) is told its slot, it does not hold the lease.
  UniqueFd fd(::open(lock_file, O_RDWR | O_CREAT | O_CLOEXEC, 0666));
  // SysError::call is a view: a static name, the file in `detail` (a temporary string there dangled and printed
  // garbage).
  if (!fd) return std::unexpected(SysError{"open(lease lock file)", errno, lock_file});
  // Every user's runs share the file (an unprivileged `rejuv run` after root's): writable by all, whatever the
  // umask made of 0666 at its creation. Only its owner can change the mode; the others find it done.
  struct stat st{};
  if (::fstat(fd.get(), &st) == 0 && st.st_uid == ::geteuid() && (st.st_mode & 0666) != 0666) {
    (void)::fchmod(fd.get(), 0666);
  }
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
  return std::unexpected(SysError{"lease_slot: every slot is taken", EBUSY, lock_file});
}

}  // namespace rejuv::sys
