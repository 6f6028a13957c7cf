// The kernel's private vocabulary, shared by its owners (impl.hpp composes them): a kernel object as routing
// sees it, the event sources of the loop, the constants of the channel input, errors and stop reasons
// (vocabulary.cpp).
#pragma once

#include <cstdarg>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rejuv/channel/codes.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::kernel {

inline constexpr Nanos kChannelCloseGrace{std::chrono::seconds{1}};  // closed fd 3 but still running: lost
inline constexpr std::size_t kFramesPerWakeup = 64;       // fairness: frames read per channel per wakeup
inline constexpr std::uint32_t kNoOrigin = 0xFFFF'FFFFU;  // the kernel / the DDS bridge

// Per kernel object: what routing needs (types, kernel endpoints, bridge, mission watch).
struct ObjectInfo {
  ObjectId id{};
  std::string name{};
  ObjectKind kind = ObjectKind::Topic;
  const msgs::TopicType* type = nullptr;  // topics only
  policy::KernelEndpoint kernel = policy::KernelEndpoint::None;
  bool is_setpoint = false;             // watched for mission_done (rejuv::msg::Setpoint)
  bool is_actuator_outputs = false;     // a control update (Fig. 7): Observer::on_control_update
  std::vector<std::byte> persistent{};  // Persistent cells (survive rollback, docs/design.md §3)
  std::vector<std::byte> limits{};      // Limits: the last LimitsWrite data
};

// What woke the loop: the source in the top byte of the epoll token, its index below.
enum class Source : std::uint8_t {
  Channel = 1, Pidfd = 2, Signal = 3, Timer = 4, Dds = 5, Plant = 6, Net = 7, Seccomp = 8, Output = 9
};
[[nodiscard]] constexpr std::uint64_t token(Source s, std::uint64_t index) {
  return (static_cast<std::uint64_t>(s) << 56U) | index;
}

// vocabulary.cpp: a KernelError without findings; whether a stop waits for the step in progress to be
// acknowledged (the others end the loop at once).
[[nodiscard]] KernelError kernel_error(KernelError::Kind kind, std::string message);
// A printf-style log line of the kernel or of an owner that logs through it (at most kMaxLogLine bytes).
inline constexpr std::size_t kMaxLogLine = 2047;
[[nodiscard]] std::string log_line(const char* format, va_list args) __attribute__((format(printf, 1, 0)));
[[nodiscard]] bool graceful(StopReason reason);

// ReplyHeader::error of an operation error (docs/protocol.md: ≥ 100): the wire's one definition.
using channel::op_code;

}  // namespace rejuv::kernel
