// The DDS domain of a test process (DESIGN §11: tests run side by side under ctest -j). Each process takes a
// domain no other test process of this machine holds: it locks /tmp/rejuv-test-dds-domain-<id>.lock (flock,
// released by the kernel when the process ends, however it ends) and keeps it for its whole life. A domain
// from the pid alone collided: two test processes whose pids agree modulo the range heard each other's
// plant (FlightMultiproc saw another mission's samples at t = 267 s, SrEndToEnd left the safety set).
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdint>
#include <string>

namespace rejuv::test_support {

// Domains 1..kTestDomains (0 is the demo's and `rejuv run`'s default).
inline constexpr std::uint32_t kTestDomains = 200;

inline std::uint32_t lock_own_dds_domain() {
  const auto start = static_cast<std::uint32_t>(::getpid()) % kTestDomains;
  for (std::uint32_t i = 0; i < kTestDomains; ++i) {
    const std::uint32_t domain = (start + i) % kTestDomains + 1;
    const std::string path = "/tmp/rejuv-test-dds-domain-" + std::to_string(domain) + ".lock";
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return domain;  // the fd stays open: the lock lasts with the process
    ::close(fd);
  }
  return start + 1;  // every domain held: share one, as before
}

// Taken once, before main (so that no test sees the lock's fd appear among its resources).
inline const std::uint32_t kOwnDdsDomain = lock_own_dds_domain();

}  // namespace rejuv::test_support
