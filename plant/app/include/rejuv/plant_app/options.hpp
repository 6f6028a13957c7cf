// Command line of the plant process `rejuv_plant` (docs/design.md §2, §6, §9): strict parsing — every flag known,
// every value in range, nothing left over — with a message that names the flag and what it expects.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include <Eigen/Core>

#include "rejuv/core/dds_name.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/dds/run_partition.hpp"

namespace rejuv::plant_app {

// Who keeps time (docs/design.md §6).
enum class ClockMode : std::uint8_t {
  Lockstep,  // the plant is the time master: step, publish SimStep, wait for the kernel's SimStepAck
  Realtime,  // physics follows CLOCK_MONOTONIC; no acks
};

struct PlantOptions {
  std::uint32_t domain = 0;  // DDS domain id
  // The run whose partition every endpoint is in (rejuv/dds/run_partition.hpp): the kernel that spawns the
  // plant passes its own. Unset: the default partition (a plant driven by a test's own participant).
  std::optional<dds::RunId> run_id{};
  // Whose names the plant's topics have on DDS (rejuv/core/dds_name.hpp): the kernel passes ROS 2's when the
  // graph's dds.ros2_names is set.
  DdsNaming naming = DdsNaming::Rejuv;
  std::uint64_t seed = 1;    // sensors and wind
  ClockMode clock = ClockMode::Lockstep;
  Eigen::Vector3d start_N_m = Eigen::Vector3d(0, 0, -3);  // hover position, NED (down −3 = 3 m up)
  Nanos duration{0};                                      // simulated (lockstep) or real time; 0 = forever
  // Pre-flight alignment: the vehicle rests at its start pose this long while the sensors publish (plant_sim.hpp);
  // 20 s like `rejuv sim` (flight::SimConfig::alignment). Counted in the duration.
  Nanos alignment{std::chrono::seconds{20}};
  Nanos step{std::chrono::milliseconds{4}};               // lockstep step; ground-truth period in realtime
  // Lockstep: no ack for this long = a kernel alive but stuck. Above the longest step the kernel may take (a cold
  // restart boots the graph inside one step: up to its 20 s boot deadline; a hung service costs its 5 s idle
  // deadline and a rollback), so that a kernel slowed by a loaded machine is waited for. A kernel that died takes
  // the plant with it (spawned with PR_SET_PDEATHSIG, sys::spawn). The one spelling of the default: --help
  // states it from here (options.cpp, usage).
  Nanos ack_timeout{std::chrono::seconds{60}};
  Nanos connect_timeout{std::chrono::seconds{30}};        // lockstep: waiting for the kernel's endpoints
  double wind_mean_m_s = 0;                               // mean wind, m/s, toward wind_toward_deg
  double wind_toward_deg = 0;                             // clockwise from north (0 = toward north)
  double wind_gust_m_s = 0;                               // gust intensity (1σ per axis), m/s
};

struct ShowHelp {};

using PlantCommand = std::variant<PlantOptions, ShowHelp>;

// args = argv[1..]. The error is one line for stderr, e.g. "--step-ms: expected an integer in [1, 1000], got
// 'x'".
[[nodiscard]] Result<PlantCommand, std::string> parse_options(std::span<const std::string_view> args);

[[nodiscard]] std::string_view usage();

[[nodiscard]] std::string_view to_string(ClockMode mode);

// Process exit codes of rejuv_plant.
inline constexpr int kExitOk = 0;          // --duration reached, SIGINT or SIGTERM
inline constexpr int kExitFailure = 1;     // DDS or system failure
inline constexpr int kExitUsage = 2;       // bad command line
inline constexpr int kExitKernelLost = 3;  // lockstep: no kernel, or no ack within --ack-timeout-ms

}  // namespace rejuv::plant_app
