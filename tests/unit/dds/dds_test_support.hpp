// Shared by the DDS tests: the loopback Cyclone config, a domain id of this test process, and a bounded wait
// for readability. The bounds are liveness guards (a broken build fails instead of hanging), never timings
// under test.
#pragma once

#include <poll.h>
#include <stdlib.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <string>

#include "../../test_domain.hpp"
#include "rejuv/dds/dds.hpp"

namespace rejuv::dds::test_support {

inline const std::string kCycloneUri = "file://" REJUV_SOURCE_DIR "/config/cyclonedds.xml";

// Loopback-only unicast (config/cyclonedds.xml); Cyclone reads it when a domain is first created.
inline void use_loopback_config() {
  ::setenv("CYCLONEDDS_URI", kCycloneUri.c_str(), 1);
}

// One domain per test process (ctest runs each test in its own process), so parallel tests never meet.
inline DomainId test_domain() { return DomainId{rejuv::test_support::kOwnDdsDomain}; }

inline constexpr auto kLiveness = std::chrono::seconds{20};

// Whether fd becomes readable within `bound`.
inline bool readable_within(int fd, std::chrono::milliseconds bound) {
  pollfd p{.fd = fd, .events = POLLIN, .revents = 0};
  const int n = ::poll(&p, 1, static_cast<int>(bound.count()));
  return n == 1 && (p.revents & POLLIN) != 0;
}

inline bool readable_now(int fd) {
  return readable_within(fd, std::chrono::milliseconds{0});
}

}  // namespace rejuv::dds::test_support
