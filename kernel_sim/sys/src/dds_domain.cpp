#include "rejuv/sys/dds_domain.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>

namespace rejuv::sys {

SysResult<DdsDomainLease> lease_dds_domain(std::uint32_t hint) {
  // Close-on-exec: a child (`rejuv run` of a sweep) is told its domain, it does not hold the lease.
  UniqueFd fd(::open(kDdsDomainLockFile, O_RDWR | O_CREAT | O_CLOEXEC, 0666));
  if (!fd) return last_error("open(/tmp/rejuv-test-dds-domains.lock)");
  for (std::uint32_t i = 0; i < kLeasedDdsDomains; ++i) {
    const std::uint32_t domain = (hint + i) % kLeasedDdsDomains + 1;
    struct flock range{};
    range.l_type = F_WRLCK;
    range.l_whence = SEEK_SET;
    range.l_start = static_cast<off_t>(domain);
    range.l_len = 1;
    if (::fcntl(fd.get(), F_OFD_SETLK, &range) == 0) return DdsDomainLease(std::move(fd), domain);
    if (errno != EAGAIN && errno != EACCES) return last_error("fcntl(F_OFD_SETLK)");
  }
  errno = EBUSY;
  return last_error("lease_dds_domain");
}

}  // namespace rejuv::sys
