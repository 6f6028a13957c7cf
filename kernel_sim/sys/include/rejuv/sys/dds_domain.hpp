// DDS domains leased between the processes of one machine (DESIGN §11): the test processes under ctest -j and
// every `rejuv sweep` mission (docs/sweep.md) each take a domain no other process of this machine holds, so
// no two of them hear each other's plant. A domain from the pid alone collided: two test processes whose
// pids agreed modulo the range heard each other's plant (FlightMultiproc saw another mission's samples at
// t = 267 s, SrEndToEnd left the safety set).
//
// One fixed file, one byte per domain: a lease is an open-file-description lock (F_OFD_SETLK) on byte
// <domain> of /tmp/rejuv-test-dds-domains.lock, which the kernel releases when the lease's fd is closed or
// its process ends, however it ends. A file per domain (flock) left one empty file behind per domain ever
// used (76 after a suite run); removing it at exit races with a process that has opened it but not yet locked
// it (both then hold "the" lock on two different inodes). A fixed set of one file needs no removal and has no
// race. OFD locks belong to the open file, not the process: two leases of one process exclude each other too.
#pragma once

#include <cstdint>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// Domains 1..kLeasedDdsDomains (0 is the demo's and `rejuv run`'s default).
inline constexpr std::uint32_t kLeasedDdsDomains = 200;
inline constexpr const char* kDdsDomainLockFile = "/tmp/rejuv-test-dds-domains.lock";

// A DDS domain held by this process until the lease is destroyed (or the process ends). Move-only.
class DdsDomainLease {
 public:
  DdsDomainLease(DdsDomainLease&&) noexcept = default;
  DdsDomainLease& operator=(DdsDomainLease&&) noexcept = default;
  [[nodiscard]] std::uint32_t domain() const { return domain_; }

 private:
  friend SysResult<DdsDomainLease> lease_dds_domain(std::uint32_t hint);
  DdsDomainLease(UniqueFd fd, std::uint32_t domain) : fd_(std::move(fd)), domain_(domain) {}
  UniqueFd fd_;
  std::uint32_t domain_ = 0;
};

// The first free domain from `hint` on (wrapping; e.g. the pid, so that processes started together spread).
// EBUSY when every domain is held; the open or fcntl error otherwise.
[[nodiscard]] SysResult<DdsDomainLease> lease_dds_domain(std::uint32_t hint);

}  // namespace rejuv::sys
