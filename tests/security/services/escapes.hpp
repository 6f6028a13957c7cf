// The escapes of the hostile-service suite (tests/security/hostile_test.cpp): what a compromised
// service tries in order to leave its sandbox (docs/design.md §7 "Protection (containment)"), one named escape per
// run, made with raw system calls where the C library would hide the call the filter sees. Each returns what
// it achieved if the process survives; the sandbox is expected to kill it inside the first forbidden call.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rejuv::test_services::escapes {

// What the test chose for the escape (the worker's params).
struct Target {
  std::uint16_t udp_port = 0;       // a loopback UDP listener of the test
  std::string path{};               // a file to create
  pid_t victim = -1;                // a process of the test's that must survive
  std::uint64_t address = 0;        // a canary in the kernel's memory (process_vm_*)
  int fd = 0;                       // the fd of TIOCSTI
  std::uint32_t hog_mb = 0;         // how much memory to take
  pid_t first_pid = -1;             // the service's first incarnation (the pid its filter was made for)
  std::uint32_t epoch = 0;          // the rollback epoch it runs in
  std::uint32_t numbers_slot = 0;   // its cap on `numbers` (Write) and the topic's message size, for frames
  std::uint32_t numbers_size = 0;   // written raw on the channel
};

// What forge_log writes and bad_frames sends (the test asserts on them).
inline constexpr std::string_view kForgedMark = "FAKE-KERNEL-ULOG";
inline constexpr double kBadFramesSent = 11;  // bad_frames: frames the kernel must refuse as bad frames

// What the escape achieved: value >= 0 the call(s) succeeded (or a count), −errno refused; detail what the
// escape says it is (a pid, a count).
struct Outcome {
  double value = 0;
  double detail = 0;
};

// Outcome::value of an escape that waits for a later epoch (reported as verdicts.hpp's EscapeReport).
inline constexpr double kNotTried = -1000;

// Performs `escape`; nullopt for an unknown name.
std::optional<Outcome> perform(std::string_view escape, const Target& target);

}  // namespace rejuv::test_services::escapes
