// Numbered slots leased between the processes of one machine (docs/design.md §11): DDS domains and the blocks of
// service uids. The test processes under ctest -j, every `rejuv sweep` mission (docs/sweep.md) and every
// kernel running as root each take a slot no other process of this machine holds.
//   - DDS domains: no two runs hear each other's plant. A domain from the pid alone collided: two test
//     processes whose pids agreed modulo the range heard each other's plant (FlightMultiproc saw another
//     mission's samples at t = 267 s, SrEndToEnd left the safety set).
//   - Service uids (docs/sandbox.md): RLIMIT_NPROC counts the processes of a uid machine-wide, so with one
//     uid per service index for every kernel, the dying processes of one run's SR cycles — or a fork bomb
//     in one run — used up the process slots of the same service in every run beside it (its next image
//     could not fork: Images.* under ctest -j), and service i of two runs shared a uid.
//
// One fixed file per kind, one byte per slot: a lease is an open-file-description lock (F_OFD_SETLK) on byte
// <slot> of the file, which the kernel releases when the lease's fd is closed or its process ends, however it
// ends. A file per slot (flock) left one empty file behind per slot ever used (76 after a suite run);
// removing it at exit races with a process that has opened it but not yet locked it (both then hold "the"
// lock on two different inodes). A fixed file needs no removal and has no race. OFD locks belong to the
// open file, not the process: two leases of one process exclude each other too.
#pragma once

#include <unistd.h>

#include <cstdint>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// A slot of a lock file held by this process until the lease is destroyed (or the process ends). Move-only.
class Lease {
 public:
  Lease(Lease&&) noexcept = default;
  Lease& operator=(Lease&&) noexcept = default;
  [[nodiscard]] std::uint32_t slot() const { return slot_; }

 private:
  friend SysResult<Lease> lease_slot(const char* lock_file, std::uint32_t first, std::uint32_t count,
                                     std::uint32_t hint);
  Lease(UniqueFd fd, std::uint32_t slot) : fd_(std::move(fd)), slot_(slot) {}
  UniqueFd fd_;
  std::uint32_t slot_ = 0;
};

// The first free slot of first..first+count-1, looking from `hint` on (wrapping; e.g. the pid, so that
// processes started together spread). EBUSY when every slot is held; the open or fcntl error otherwise.
[[nodiscard]] SysResult<Lease> lease_slot(const char* lock_file, std::uint32_t first, std::uint32_t count,
                                          std::uint32_t hint);

// DDS domains 1..kLeasedDdsDomains (0 is the demo's and `rejuv run`'s default). Every UDP port of a leased
// domain lies below Linux's ephemeral range (32768 onwards by default): a domain's RTPS ports start at
// 7400 + 250·domain, and discovery (config/cyclonedds.xml: unicast to localhost, participant indices up to
// kMaxParticipantIndex) sends to the next 10 + 2·(index + 1) of them whether a participant holds the port or not.
// Were those ports in the ephemeral range, a socket bound to port 0 — a test's UDP listener that must see no
// datagram, a network gate on `--net-port 0` — could be given one and receive another run's discovery.
inline constexpr std::uint32_t kLeasedDdsDomains = 100;
inline constexpr std::uint32_t kMaxParticipantIndex = 100;  // config/cyclonedds.xml MaxAutoParticipantIndex
inline constexpr std::uint32_t kEphemeralPortsFrom = 32768;
static_assert(7400 + 250 * kLeasedDdsDomains + 10 + 2 * (kMaxParticipantIndex + 1) < kEphemeralPortsFrom,
              "a leased DDS domain would send discovery into the ephemeral port range");
inline constexpr const char* kDdsDomainLockFile = "/tmp/rejuv-test-dds-domains.lock";
using DdsDomainLease = Lease;  // slot() is the domain
[[nodiscard]] inline SysResult<DdsDomainLease> lease_dds_domain(std::uint32_t hint) {
  return lease_slot(kDdsDomainLockFile, 1, kLeasedDdsDomains, hint);
}
// The rule of the `rejuv` commands (a run, a soak, a job pool's worker `index`): searched from the process's pid,
// workers 41 apart, so that commands started together look for free domains in different places.
[[nodiscard]] inline SysResult<DdsDomainLease> lease_dds_domain_for_worker(std::uint32_t index) {
  return lease_dds_domain(static_cast<std::uint32_t>(::getpid()) + 41 * index);
}

// Blocks of service uids for kernels running as root: block b is kServiceUidBase + b·kUidsPerBlock onwards,
// one uid per service. Above 65535, so that no block reaches nobody (65534) or a system range.
inline constexpr std::uint32_t kServiceUidBase = 100000;
inline constexpr std::uint32_t kUidsPerBlock = 256;  // services per graph a kernel as root can run
inline constexpr std::uint32_t kUidBlocks = 1024;
inline constexpr const char* kUidBlockLockFile = "/tmp/rejuv-service-uids.lock";
static_assert(kServiceUidBase > 65534, "no block may reach nobody (65534)");
[[nodiscard]] inline SysResult<Lease> lease_uid_block(std::uint32_t hint) {
  return lease_slot(kUidBlockLockFile, 0, kUidBlocks, hint);
}
// The uid of service `index` (< kUidsPerBlock) in a leased block.
[[nodiscard]] inline std::uint32_t service_uid(const Lease& block, std::uint32_t index) {
  return kServiceUidBase + block.slot() * kUidsPerBlock + index;
}

}  // namespace rejuv::sys
