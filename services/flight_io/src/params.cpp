#include "rejuv/flight_io/params.hpp"

#include <cmath>
#include <cstdio>
#include <utility>

#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/plant/sensors.hpp"

namespace rejuv::flight_io {

std::string_view to_string(InputError error) {
  switch (error) {
    case InputError::Missing: return "missing";
    case InputError::NotFinite: return "not a finite number";
    case InputError::OutOfRange: return "out of range";
    case InputError::Design: return "refused by the control design";
  }
  return "invalid";
}

std::string InputFailure::to_string() const {
  return where + ": " + std::string(flight_io::to_string(kind)) + ": " + message;
}

Params Params::from_table(std::map<std::string, graph_values::Value, std::less<>> table) {
  return Params([table = std::move(table)](std::string_view name) -> std::optional<graph_values::Value> {
    const auto it = table.find(name);
    if (it == table.end()) return std::nullopt;
    return it->second;
  });
}

std::optional<double> Params::find(std::string_view name) const {
  const std::optional<graph_values::Value> v = lookup_(name);
  if (!v) return std::nullopt;
  if (const auto* i = std::get_if<std::int64_t>(&*v)) return static_cast<double>(*i);
  return std::get<double>(*v);
}

InputFailure failure_of(const graph_values::ValueError& error) {
  InputError kind = InputError::OutOfRange;
  switch (error.kind) {
    case graph_values::ValueError::Kind::NotFinite: kind = InputError::NotFinite; break;
    case graph_values::ValueError::Kind::WrongType:
    case graph_values::ValueError::Kind::OutOfRange: kind = InputError::OutOfRange; break;
  }
  return InputFailure{.kind = kind, .where = error.key, .message = error.message};
}

namespace {

std::string number_text(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

InputFailure failure(InputError kind, std::string where, std::string message) {
  return InputFailure{.kind = kind, .where = std::move(where), .message = std::move(message)};
}

// The param if present, checked finite.
Result<std::optional<double>, InputFailure> finite_param(const Params& params, std::string_view name) {
  const std::optional<double> v = params.find(name);
  if (v && !std::isfinite(*v)) {
    return fail(failure(InputError::NotFinite, std::string(name), "expected a finite number"));
  }
  return v;
}

// A finite param, or `fallback` when absent.
Result<double, InputFailure> number_or(const Params& params, std::string_view name, double fallback) {
  auto v = finite_param(params, name);
  if (!v) return fail(std::move(v.error()));
  return v->value_or(fallback);
}

// A finite param > 0 (or >= 0 when `zero_ok`), or `fallback` when absent.
Result<double, InputFailure> positive_or(const Params& params, std::string_view name, double fallback,
                                         bool zero_ok = false) {
  auto v = number_or(params, name, fallback);
  if (!v) return v;
  if (*v < 0.0 || (!zero_ok && *v == 0.0)) {
    return fail(failure(InputError::OutOfRange, std::string(name),
                        std::string(zero_ok ? "expected a value >= 0" : "expected a value > 0") + ", got " +
                            number_text(*v)));
  }
  return v;
}

flight::VehicleParams vehicle_of(const plant::QuadParams& quad) {
  // As flight::SrSimulation::create: the controllers are designed on the vehicle of the plant.
  return flight::VehicleParams{.mass_kg = quad.mass_kg,
                               .inertia_diag_kg_m2 = quad.inertia_B_kg_m2.diagonal(),
                               .gravity_m_s2 = quad.gravity_m_s2,
                               .k1_N = quad.max_thrust_per_motor_N,
                               .k2_N_m = quad.max_torque_per_motor_N_m,
                               .arm_m = quad.arm_length_m};
}

}  // namespace

Result<TrackingParams, InputFailure> tracking_params(const Params& params) {
  namespace gv = graph_values;
  auto enabled = read(params, gv::kEnabled);
  if (!enabled) return fail(std::move(enabled.error()));
  auto rho_m = read(params, gv::kRhoM);
  if (!rho_m) return fail(std::move(rho_m.error()));
  auto rho_s = read(params, gv::kRhoS);
  if (!rho_s) return fail(std::move(rho_s.error()));
  // The launch loader checks the same (§IV-A): E(ρ_s) ⊂ E(ρ_M) ⊆ the safety set.
  if (!(*rho_s < *rho_m)) {
    return fail(failure(InputError::OutOfRange, std::string(gv::kRhoS.name),
                        "the tracking algorithm needs 0 < rho_s < rho_m <= 1 (§IV-A), got rho_s = " +
                            number_text(*rho_s) + ", rho_m = " + number_text(*rho_m)));
  }
  auto t_min = read(params, gv::kTmin);
  if (!t_min) return fail(std::move(t_min.error()));
  auto check = read(params, gv::kCheckPeriod);
  if (!check) return fail(std::move(check.error()));
  return TrackingParams{.sr = *enabled ? flight::SrSwitch::On : flight::SrSwitch::Off,
                        .rho_M = *rho_m,
                        .rho_s = *rho_s,
                        .t_min = to_seconds(*t_min),
                        .check_period = to_seconds(*check)};
}

flight::HandlerTiming SrCycleParams::handler_timing() const {
  return flight::HandlerTiming{.t_est = t_est,
                               .t_min = tracking.t_min,
                               .check_period = tracking.check_period,
                               .rho_s = tracking.rho_s};
}

Result<SrCycleParams, InputFailure> sr_cycle_params(const Params& params) {
  auto tracking = tracking_params(params);
  if (!tracking) return fail(std::move(tracking.error()));
  auto t_mc = read(params, graph_values::kTmc);
  if (!t_mc) return fail(std::move(t_mc.error()));
  auto t_est = read(params, graph_values::kTest);
  if (!t_est) return fail(std::move(t_est.error()));
  return SrCycleParams{.tracking = *tracking, .t_mc = to_seconds(*t_mc), .t_est = to_seconds(*t_est)};
}

Result<flight::ControlDesignSpec, InputFailure> control_spec(const Params& params) {
  const flight::SimConfig sim = flight::SimConfig::defaults();
  flight::ControlDesignSpec spec = sim.control;
  spec.vehicle = vehicle_of(sim.quad);
  spec.control_period = to_seconds(sim.sensors.gyro_period);
  const std::pair<const graph_values::Key<double>*, double*> box[] = {
      {&graph_values::kBoxPosition, &spec.box.position_m},
      {&graph_values::kBoxVelocity, &spec.box.velocity_m_s},
      {&graph_values::kBoxAngle, &spec.box.angle_rad},
      {&graph_values::kBoxRate, &spec.box.rate_rad_s},
  };
  for (const auto& [key, field] : box) {
    auto v = read(params, *key);
    if (!v) return fail(std::move(v.error()));
    *field = *v;
  }
  auto fraction = read(params, graph_values::kRestrictedLimitFraction);
  if (!fraction) return fail(std::move(fraction.error()));
  spec.restricted_limit_fraction = *fraction;
  return spec;
}

Result<flight::ControlDesign, InputFailure> control_design(const Params& params) {
  auto spec = control_spec(params);
  if (!spec) return fail(std::move(spec.error()));
  auto design = flight::design_control(*spec);
  if (!design) {
    std::string where = "sr";
    switch (design.error().kind) {
      case flight::DesignError::Limits: where = graph_values::kRestrictedLimitFraction.name; break;
      case flight::DesignError::Ellipsoid: where = "sr.box"; break;
      case flight::DesignError::Vehicle:
      case flight::DesignError::Model:
      case flight::DesignError::MissionLqr:
      case flight::DesignError::SafetyLqr: where = "plant"; break;
    }
    return fail(failure(InputError::Design, std::move(where), design.error().to_string()));
  }
  return std::move(*design);
}

Result<ActuatorLimits, InputFailure> actuator_limits(const Params& params) {
  auto spec = control_spec(params);
  if (!spec) return fail(std::move(spec.error()));
  // The same calls, in the same order, as flight::design_control.
  auto vehicle = flight::validate(spec->vehicle);
  if (!vehicle) return fail(failure(InputError::Design, "plant", vehicle.error().message));
  auto restricted = flight::restricted_limits(*vehicle, spec->restricted_limit_fraction);
  if (!restricted) {
    return fail(failure(InputError::Design, std::string(graph_values::kRestrictedLimitFraction.name),
                        restricted.error().message));
  }
  return ActuatorLimits{.full = flight::full_limits(*vehicle),
                        .restricted = *restricted,
                        .u_hover = flight::hover_input(*vehicle)};
}

Result<MissionSpec, InputFailure> mission_params(const Params& params) {
  const flight::SimConfig sim = flight::SimConfig::defaults();
  MissionSpec m{
      .waypoints = sim.waypoints, .acceptance_radius_m = sim.acceptance_radius_m, .from_defaults = false};
  auto radius = positive_or(params, "mission.acceptance_radius_m", 0.0, /*zero_ok=*/true);
  if (!radius) return fail(std::move(radius.error()));
  if (*radius > 0.0) m.acceptance_radius_m = *radius;  // 0 = the default (config_from_launch)

  auto count = finite_param(params, "mission.count");
  if (!count) return fail(std::move(count.error()));
  if (!*count) {
    m.from_defaults = true;
    return m;
  }
  const double n = **count;
  if (n != std::floor(n) || n < 1.0 || n > static_cast<double>(kMaxWaypoints)) {
    return fail(failure(InputError::OutOfRange, "mission.count",
                        "expected a whole number of waypoints in [1, " + std::to_string(kMaxWaypoints) +
                            "], got " + number_text(n)));
  }
  m.waypoints.clear();
  const auto count_n = static_cast<std::size_t>(n);
  for (std::size_t i = 0; i < count_n; ++i) {
    const std::string prefix = "mission." + std::to_string(i) + ".";
    flight::PathWaypoint w;
    const std::pair<const char*, double*> coords[] = {
        {"north_m", &w.p_N_m.x()}, {"east_m", &w.p_N_m.y()}, {"down_m", &w.p_N_m.z()}};
    for (const auto& [field, value] : coords) {
      const std::string name = prefix + field;
      auto v = finite_param(params, name);
      if (!v) return fail(std::move(v.error()));
      if (!*v) {
        return fail(failure(InputError::Missing, name,
                            "waypoint " + std::to_string(i) + " of " + std::to_string(count_n) +
                                " needs north_m, east_m and down_m"));
      }
      *value = **v;
    }
    auto yaw = number_or(params, prefix + "yaw_rad", 0.0);
    if (!yaw) return fail(std::move(yaw.error()));
    w.yaw_rad = *yaw;
    m.waypoints.push_back(w);
  }
  return m;
}

Result<ControlStart, InputFailure> control_start(const Params& params) {
  auto design = control_design(params);
  if (!design) return fail(std::move(design.error()));
  auto mission = mission_params(params);
  if (!mission) return fail(std::move(mission.error()));
  const flight::PathWaypoint& first = mission->waypoints.front();
  return ControlStart{.design = std::move(*design), .x_sp = flight::hover_setpoint(first.p_N_m, first.yaw_rad)};
}

Nanos imu_period() {
  return plant::SensorParams::defaults().gyro_period;
}

flight::EkfParams ekf_params() {
  // As flight::SrSimulation::create.
  const flight::SimConfig sim = flight::SimConfig::defaults();
  flight::EkfParams p = sim.ekf;
  p.gps_delay = to_seconds(sim.sensors.gps_delay);
  p.gravity_m_s2 = sim.quad.gravity_m_s2;
  p.drag_over_mass_per_s = sim.quad.drag_coefficient_N_s_m / sim.quad.mass_kg;
  return p;
}

Result<flight::EkfRearm, InputFailure> ekf_rearm(const Params& params) {
  flight::EkfRearm r;
  auto on = read(params, graph_values::kRearmEnabled);
  if (!on) return fail(std::move(on.error()));
  r.enabled = *on;
  for (const flight::EkfRearm::StdField& f : flight::EkfRearm::kStdFields) {
    const graph_values::Key<double>* key = graph_values::rearm_std(f.name);
    REJUV_ASSERT(key != nullptr, "an EkfRearm 1σ without a key in rejuv/core/graph_values.hpp");
    auto v = read(params, *key);  // a 1σ: finite, > 0
    if (!v) return fail(std::move(v.error()));
    r.*f.member = *v;
  }
  return r;
}

flight::EkfState ekf_initial_state(const MissionSpec& mission) {
  // As flight::SrSimulation::create: hovering at rest at the first waypoint, level, with its yaw.
  const flight::PathWaypoint first =
      mission.waypoints.empty() ? flight::PathWaypoint{} : mission.waypoints.front();
  const plant::QuadState hover = plant::Quadrotor::hover_at(flight::SimConfig::defaults().quad, first.p_N_m);
  return flight::EkfState{
      .p_N_m = hover.p_NB_N,
      .v_N_m_s = hover.v_NB_N,
      .q_NB = Eigen::Quaterniond(Eigen::AngleAxisd(first.yaw_rad, Eigen::Vector3d::UnitZ()))};
}

}  // namespace rejuv::flight_io
