// The raw Cyclone DDS latency baseline (docs/design.md §11): ping-pong between this process and an echo process
// (rejuv_dds_echo) over loopback, on a real topic type. Two receive paths:
//   RawWaitset     — Cyclone's C API alone: waitset on a read condition, dds_take. The baseline.
//   BridgeEventFd  — rejuv::dds (the kernel's DDS bridge): listener → eventfd → poll → Reader::take.
// The kernel's publish→deliver path (two services through the kernel over Unix seqpacket channels) is
// measured with the same loop and statistics (latency.hpp) and reported beside these numbers.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/dds/dds.hpp"

namespace rejuv::bench {

enum class DdsPath : std::uint8_t { RawWaitset, BridgeEventFd };

[[nodiscard]] std::string_view to_string(DdsPath path);

struct PingPongOptions {
  dds::DomainId domain{};
  std::string type_name = "rejuv::msg::VehicleStateEstimate";  // any topic type of ≥ 8 bytes
  DdsPath path = DdsPath::RawWaitset;
  std::string echo_executable{};                 // path of rejuv_dds_echo
  std::string cyclone_uri{};                     // CYCLONEDDS_URI for both processes
  std::size_t warmup_round_trips = 200;          // after the first reply, not recorded
  Nanos reply_timeout{std::chrono::seconds{5}};  // a lost reply ends the run with an error
  Nanos connect_timeout{std::chrono::seconds{20}};
};

// A connected ping-pong pair: this process's endpoint and a live echo process. Move-only; the destructor
// closes the echo's control pipe (it exits), then reaps it (killing it if it does not exit).
class DdsPingPong {
 public:
  // Spawns the echo, waits for both directions to match and for a first reply, then warms up.
  [[nodiscard]] static Result<DdsPingPong, std::string> start(const PingPongOptions& options);

  DdsPingPong(DdsPingPong&&) noexcept;
  DdsPingPong& operator=(DdsPingPong&&) noexcept;
  DdsPingPong(const DdsPingPong&) = delete;
  DdsPingPong& operator=(const DdsPingPong&) = delete;
  ~DdsPingPong();

  // One ping with sequence number `seq` (written into the payload's first 8 bytes) and its echo.
  [[nodiscard]] Result<void, std::string> round_trip(std::uint64_t seq);
  // `count` timed round trips: the round-trip times.
  [[nodiscard]] Result<std::vector<Nanos>, std::string> run(std::size_t count);

  [[nodiscard]] std::size_t payload_size() const;

 private:
  struct Impl;
  explicit DdsPingPong(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Topic names of the benchmark (never used by a launch graph).
inline constexpr std::string_view kPingTopic = "rejuv_bench/ping";
inline constexpr std::string_view kPongTopic = "rejuv_bench/pong";

}  // namespace rejuv::bench
