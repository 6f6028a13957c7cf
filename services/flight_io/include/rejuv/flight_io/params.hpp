// The launch-graph parameters of the flight services (docs/design.md §10), read into the configuration types of the
// flight libraries. Every derived number is formed the way flight::SrSimulation::create forms it, so that
// `rejuv run` flies exactly like `rejuv sim` for the same graph. The services read only graph-wide params that
// the kernel passes to every service (sdk/service.hpp "Params"):
//
//   the SR scheme's keys (sr.*), each read through its typed key of rejuv/core/graph_values.hpp, which gives its
//   default and its range (durations cross as integer ns);
//   mission.count, mission.acceptance_radius_m,
//   mission.<i>.north_m, mission.<i>.east_m, mission.<i>.down_m (required), mission.<i>.yaw_rad (default 0)
//
// A missing param takes its default; a present but wrong one is refused with its name.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight/ekf.hpp"
#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight/limits.hpp"
#include "rejuv/flight/setpoint.hpp"
#include "rejuv/flight/sim_config.hpp"

namespace rejuv::flight_io {

// What is wrong with a param or a message field.
enum class InputError : std::uint8_t {
  Missing,     // a required value is absent (e.g. one coordinate of a waypoint)
  NotFinite,   // NaN or infinite
  OutOfRange,  // outside the range the flight code accepts (e.g. more than 16 waypoints)
  Design,      // the numbers are valid one by one but the control design refuses them
};
[[nodiscard]] std::string_view to_string(InputError error);

struct InputFailure {
  InputError kind = InputError::Missing;
  std::string where{};    // the param or field, e.g. "mission.3.east_m"
  std::string message{};  // what was expected
  // "mission.3.east_m: missing: every waypoint needs north_m, east_m and down_m".
  [[nodiscard]] std::string to_string() const;
};

// A read-only view of a service's numeric params: sdk::Service::param_value in a process (sdk_params.hpp), a
// table in tests. `value` is the param as it crossed (a double or an integer), nullopt when absent; `find` reads
// either as a double.
class Params {
 public:
  using Lookup = std::function<std::optional<graph_values::Value>(std::string_view name)>;
  explicit Params(Lookup lookup) : lookup_(std::move(lookup)) {}
  [[nodiscard]] static Params from_table(std::map<std::string, graph_values::Value, std::less<>> table);

  [[nodiscard]] std::optional<graph_values::Value> value(std::string_view name) const { return lookup_(name); }
  [[nodiscard]] std::optional<double> find(std::string_view name) const;

 private:
  Lookup lookup_;
};

// The typed value of a graph-wide key (rejuv/core/graph_values.hpp): its default when absent; out of its range,
// wrongly typed or not finite, a failure naming the key.
[[nodiscard]] InputFailure failure_of(const graph_values::ValueError& error);
template <class T>
[[nodiscard]] Result<T, InputFailure> read(const Params& params, const graph_values::Key<T>& key) {
  auto v = graph_values::read(key, params.value(key.name));
  if (!v) return fail(failure_of(v.error()));
  return *v;
}

// The tracking numbers of the SR scheme (§IV-A, §V-B). Also used without SR: Table I's configurations run
// the same tracking algorithm (flight/sim/sr_sim.hpp).
struct TrackingParams {
  flight::SrSwitch sr = graph_values::kEnabled.fallback ? flight::SrSwitch::On : flight::SrSwitch::Off;
  double rho_M = graph_values::kRhoM.fallback;  // the update keeps x̂ ∈ E(ρ_M, x_sp')
  double rho_s = graph_values::kRhoS.fallback;  // condition (1): ‖x̂ − x_sp‖_P < ρ_s
  Seconds t_min = to_seconds(graph_values::kTmin.fallback);                // hold after a setpoint move
  Seconds check_period = to_seconds(graph_values::kCheckPeriod.fallback);  // how often (1) is checked
};
// sr.enabled, sr.rho_m, sr.rho_s, sr.t_min_s, sr.check_period_s; each in its key's range, and ρ_s < ρ_M (§IV-A).
[[nodiscard]] Result<TrackingParams, InputFailure> tracking_params(const Params& params);

// The timing of one SR cycle (§II Fig. 2, §V-B) for checkpoint_p's rollback handler: T_MC (the rejuvenation
// timer, do_timer(T_MC, 0) of §V-A) and T_est (time in SC before the first check of (1)), with the tracking
// numbers the handler checks and requests.
struct SrCycleParams {
  TrackingParams tracking{};
  Seconds t_mc = to_seconds(graph_values::kTmc.fallback);
  Seconds t_est = to_seconds(graph_values::kTest.fallback);
  // The model-level handler's timing (flight::RollbackHandler), as flight::config_from_launch forms it.
  [[nodiscard]] flight::HandlerTiming handler_timing() const;
};
// tracking_params, sr.t_mc_s and sr.t_est_s, in their keys' ranges.
[[nodiscard]] Result<SrCycleParams, InputFailure> sr_cycle_params(const Params& params);

// The control design spec of the simulation: the plant's quad (jMAVSim default) as the vehicle, the IMU
// period as the control period, sr.box.* and sr.restricted_limit_fraction.
[[nodiscard]] Result<flight::ControlDesignSpec, InputFailure> control_spec(const Params& params);
// design_control(control_spec(params)): gains, P and both limit boxes (docs/design.md §9).
[[nodiscard]] Result<flight::ControlDesign, InputFailure> control_design(const Params& params);

// The actuator limits alone (output_driver needs no gains): U, Ū and u_hover exactly as design_control
// computes them.
struct ActuatorLimits {
  flight::InputBox full{};        // U
  flight::InputBox restricted{};  // Ū
  flight::InputVec u_hover = flight::InputVec::Zero();
};
[[nodiscard]] Result<ActuatorLimits, InputFailure> actuator_limits(const Params& params);

// The mission (§IV-B: ordered waypoints W). Without mission.count the simulation's default mission (the
// §VI-C square) is used; with it, 1 ≤ count ≤ 16 and every waypoint needs its three coordinates.
// mission.acceptance_radius_m: absent or 0 → 0.05 m (as config_from_launch), otherwise > 0 and finite.
inline constexpr std::size_t kMaxWaypoints = 16;  // idl/control.idl MissionWaypoints.waypoints[16]
struct MissionSpec {
  std::vector<flight::PathWaypoint> waypoints{};
  double acceptance_radius_m = 0.05;
  bool from_defaults = false;  // no mission.count: the simulation's default mission
};
[[nodiscard]] Result<MissionSpec, InputFailure> mission_params(const Params& params);

// What a controller starts from (lqr_control, safety_control, checkpoint_p's handler): the control design,
// and the hover at the mission's first waypoint as the setpoint until the first Setpoint arrives.
struct ControlStart {
  flight::ControlDesign design;
  flight::StateVec x_sp;  // hover_setpoint(first waypoint)
};
// control_design, then mission_params; the first failure.
[[nodiscard]] Result<ControlStart, InputFailure> control_start(const Params& params);

// The IMU period of the plant's sensor suite (gyro and accel, 250 Hz): the estimator's step and the
// controllers' period.
[[nodiscard]] Nanos imu_period();
// The EKF parameters of the simulation (defaults; GPS delay and gravity from the sensor suite and the quad).
[[nodiscard]] flight::EkfParams ekf_params();
// The estimator's re-arm on a rollback (flight::EstimatorNode::on_rollback): the launch file's sr.ekf_rearm.*
// as the kernel passes them (only those it sets), the simulation's defaults for the rest. A 1σ that is not a
// finite number > 0, or an `enabled` other than 0 or 1, is an error.
[[nodiscard]] Result<flight::EkfRearm, InputFailure> ekf_rearm(const Params& params);
// The state the EKF starts from: hovering at the first waypoint, heading as it says (the simulation's
// initial state, which is also where the plant starts).
[[nodiscard]] flight::EkfState ekf_initial_state(const MissionSpec& mission);

}  // namespace rejuv::flight_io
