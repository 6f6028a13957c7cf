// The configuration of the flight software and its vehicle, with the defaults of the experiment of §VI-C
// (docs/design.md §9). Without protobuf or the simulation engine: the flight services take their defaults from here
// (services/flight_io), the simulation (sr_sim.hpp) fills it from a launch graph.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/flight/attack_library.hpp"
#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight/ekf.hpp"
#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight/rollback_handler.hpp"
#include "rejuv/flight/setpoint.hpp"
#include "rejuv/plant/plant.hpp"

namespace rejuv::flight {

enum class SrSwitch : std::uint8_t { On, Off };
enum class AttackSwitch : std::uint8_t { On, Off };

// The attack of the plan that acts on the vehicle: the worst-case control of §VI-D or another law of the
// attack library.
struct AttackConfig {
  AttackSwitch enabled = AttackSwitch::On;
  AttackLaw law = AttackLaw::WorstCaseControl;
  double magnitude = 0.0;  // 0 = the law's default (attack_library.hpp)
  Seconds start{0};               // first MC window at or after this time
  std::uint32_t max_windows = 0;  // 0 = every MC window
};

// Everything one run needs. `defaults()` is the experiment of §VI-C (the square at 3 m) with this project's
// tuning; `config_from_launch` fills it from a launch graph.
struct SimConfig {
  std::string graph_name = "quad_square";
  SrSwitch sr = graph_values::kEnabled.fallback ? SrSwitch::On : SrSwitch::Off;  // defaults: graph_values.hpp
  std::uint64_t seed = 1;
  Seconds t_mc = to_seconds(graph_values::kTmc.fallback);
  // T_RB and T_CP: the times the software is stopped for a rollback and a checkpoint, controls held. The paper
  // measured ≈15 ms and ≈20 ms on PX4 (§VI-B, Fig. 7); the model charges the same to simulated time.
  Seconds t_rb{0.015};
  Seconds t_cp{0.020};
  HandlerTiming handler;
  double rho_M = graph_values::kRhoM.fallback;
  std::uint32_t keep_generations = graph_values::kKeepGenerations.fallback;
  AttackConfig attack;
  ControlDesignSpec control;
  plant::QuadParams quad = plant::QuadParams::jmavsim_default();
  plant::SensorParams sensors = plant::SensorParams::defaults();
  plant::WindParams wind;
  EkfParams ekf = EkfParams::defaults();
  EkfRearm ekf_rearm;
  // Estimate catch-up (launch sr.estimate_catch_up): at a rollback the plant's sensor samples since the
  // checkpoint are replayed through the restored estimator instead of re-arming its covariance; the replay is
  // charged to the rollback's stop at this much per sample (launch lockstep.catch_up_charge_us_per_sample).
  bool estimate_catch_up = false;
  Nanos catch_up_charge_per_sample{std::chrono::microseconds{2}};
  std::vector<PathWaypoint> waypoints;
  double acceptance_radius_m = 0.05;
  Seconds timeout{600};
  Seconds physics_step{0.001};
  // Pre-flight alignment: the mission starts hovering at the first waypoint (§IV-B), with an estimator that has
  // converged there; modelled by feeding the EKF this much sensor data of that hover before t = 0.
  Seconds alignment{20.0};
  // A run ends early once V = ‖x − x_sp‖²_P exceeds this (the vehicle is lost; nothing more to measure).
  double lost_V = 100.0;
  // With SR: the run ends (summary's stopped_after_attacks) when an MC window begins after this many attacked
  // ones (0 = never), the launch's stop_after_attacks (`rejuv sweep --attacks`, §VI-D's 45 attacks per cell).
  std::uint32_t stop_after_attacks = 0;

  [[nodiscard]] static SimConfig defaults();
};

// The control design the engine runs: `config.control` on the plant's vehicle (mass, inertia, k1, k2, L of
// plant::QuadParams) at the IMU rate of its sensors.
[[nodiscard]] ControlDesignSpec control_spec_for(const SimConfig& config);

}  // namespace rejuv::flight
