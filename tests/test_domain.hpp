// The DDS domain of a test process (DESIGN §11: tests run side by side under ctest -j). Each process takes a
// domain no other test process of this machine holds and keeps it for its whole life. A domain from the pid
// alone collided: two test processes whose pids agree modulo the range heard each other's plant
// (FlightMultiproc saw another mission's samples at t = 267 s, SrEndToEnd left the safety set).
//
// One fixed file, one byte per domain: the process holds an open-file-description lock (F_OFD_SETLK) on
// byte <domain> of /tmp/rejuv-test-dds-domains.lock, which the kernel releases when the process ends,
// however it ends. A file per domain (flock) left one empty file behind per domain ever used (76 after a
// suite run); removing it at exit races with a process that has opened it but not yet locked it (both
// then hold "the" lock on two different inodes). A fixed set of one file needs no removal and has no race.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstdint>

namespace rejuv::test_support {

// Domains 1..kTestDomains (0 is the demo's and `rejuv run`'s default).
inline constexpr std::uint32_t kTestDomains = 200;
inline constexpr const char* kDomainLockFile = "/tmp/rejuv-test-dds-domains.lock";

inline std::uint32_t lock_own_dds_domain() {
  const auto start = static_cast<std::uint32_t>(::getpid()) % kTestDomains;
  // Kept open (no CLOEXEC-free leak: exec'd children do not inherit it) for the life of the process.
  const int fd = ::open(kDomainLockFile, O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd < 0) return start + 1;  // no lock file possible: share one, as before
  for (std::uint32_t i = 0; i < kTestDomains; ++i) {
    const std::uint32_t domain = (start + i) % kTestDomains + 1;
    struct flock range{};
    range.l_type = F_WRLCK;
    range.l_whence = SEEK_SET;
    range.l_start = static_cast<off_t>(domain);
    range.l_len = 1;
    if (::fcntl(fd, F_OFD_SETLK, &range) == 0) return domain;  // held until the process ends
  }
  ::close(fd);
  return start + 1;  // every domain held: share one, as before
}

// Taken once, before main (so that no test sees the lock's fd appear among its resources).
inline const std::uint32_t kOwnDdsDomain = lock_own_dds_domain();

}  // namespace rejuv::test_support
