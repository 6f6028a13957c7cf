// The DDS domain of a test process (docs/design.md §11: tests run side by side under ctest -j): a lease of
// rejuv/sys/lease.hpp (the lock file shared with `rejuv sweep`), held for the test process's whole life.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <optional>

#include "rejuv/sys/lease.hpp"

namespace rejuv::test_support {

inline constexpr std::uint32_t kTestDomains = sys::kLeasedDdsDomains;
inline constexpr const char* kDomainLockFile = sys::kDdsDomainLockFile;

inline std::uint32_t lock_own_dds_domain() {
  const auto start = static_cast<std::uint32_t>(::getpid()) % kTestDomains;
  // Kept for the life of the process (close-on-exec: exec'd children do not inherit it).
  static std::optional<sys::DdsDomainLease> lease;
  auto taken = sys::lease_dds_domain(start);
  if (!taken) return start + 1;  // no lock file possible, or every domain held: share one, as before
  lease.emplace(std::move(*taken));
  return lease->slot();
}

// Taken once, before main (so that no test sees the lock's fd appear among its resources).
inline const std::uint32_t kOwnDdsDomain = lock_own_dds_domain();

}  // namespace rejuv::test_support
