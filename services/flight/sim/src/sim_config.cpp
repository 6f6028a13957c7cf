#include <cmath>

#include "rejuv/flight/detail/printf.hpp"
#include "rejuv/flight/sr_sim.hpp"

namespace rejuv::flight {

namespace {

using Step = TextLocations::Step;

LoadError semantic(SourceLocation where, std::string message) {
  return LoadError{LoadErrorKind::Semantic, std::move(where), std::move(message)};
}

using Filled = Result<void, LoadError>;

SourceLocation sr_at(const TextLocations& at, std::string_view field) { return at.locate({Step{"sr", -1}}, field); }

// The EKF re-arm after a restore: its switch and its 1-sigma fields, by name.
void ekf_rearm_from(EkfRearm& out, const proto::SrParams& sr) {
  for (const launch::RearmField& f : launch::ekf_rearm_fields(sr.ekf_rearm())) {
    if (f.is_switch) out.enabled = f.value == 1.0;
    for (const EkfRearm::StdField& s : EkfRearm::kStdFields) {
      if (s.name == f.name) out.*s.member = f.value;
    }
  }
}

// SR parameters. The tracking algorithm uses ρ_s, ρ_M, t_min, the check period and P also without SR, so they
// are checked here whether or not sr.enabled (load_launch skips them for a disabled scheme).
Filled sr_from_launch(SimConfig& c, const proto::Launch& g, const TextLocations& at,
                      const std::optional<SrSwitch>& sr_override) {
  const proto::SrParams& sr = g.sr();
  c.sr = sr_override.value_or(sr.enabled() ? SrSwitch::On : SrSwitch::Off);
  c.t_mc = launch::t_mc(sr);
  c.handler.t_est = launch::t_est(sr);
  c.handler.t_min = launch::t_min(sr);
  c.handler.check_period = launch::check_period(sr);
  c.handler.rho_s = sr.rho_s();
  c.rho_M = sr.rho_m();
  c.keep_generations = launch::keep_generations(sr);
  c.estimate_catch_up = sr.estimate_catch_up();
  c.catch_up_charge_per_sample = std::chrono::round<Nanos>(launch::catch_up_charge_per_sample(g.lockstep()));
  ekf_rearm_from(c.ekf_rearm, sr);
  if (!(std::isfinite(sr.rho_s()) && std::isfinite(sr.rho_m()) && sr.rho_s() > 0.0 && sr.rho_s() < sr.rho_m() &&
        sr.rho_m() <= 1.0)) {
    return fail(semantic(sr_at(at, "rho_s"), detail::printf_string("the tracking algorithm needs 0 < rho_s < rho_m <= 1 "
                                                                   "(§IV-A), got rho_s = %g, rho_m = %g",
                                                                   sr.rho_s(), sr.rho_m())));
  }
  if (c.sr == SrSwitch::On && !(c.t_mc.count() > 0.0)) {
    const auto& key = graph_values::kTmc;
    return fail(semantic(sr_at(at, graph_values::field_of(key.name)),
                         std::string(key.name) + " (" + std::string(key.symbol) + ") must be > 0 s"));
  }
  if (!(c.handler.check_period.count() > 0.0) || !(c.handler.t_min.count() >= 0.0) ||
      !(c.handler.t_est.count() >= 0.0)) {
    const auto& key = graph_values::kCheckPeriod;
    return fail(semantic(sr_at(at, graph_values::field_of(key.name)),
                         std::string(key.name) + " must be > 0 s, t_min_s and t_est_s >= 0 s"));
  }
  const proto::StateBox& box = sr.box();
  c.control.box = StateBox{.position_m = box.position_m(),
                           .velocity_m_s = box.velocity_m_s(),
                           .angle_rad = box.angle_rad(),
                           .rate_rad_s = box.rate_rad_s()};
  c.control.restricted_limit_fraction = sr.restricted_limit_fraction();
  return {};
}

Filled mission_from_launch(SimConfig& c, const proto::Mission& m, const TextLocations& at) {
  if (m.waypoints_size() == 0) {
    return fail(semantic(at.locate({}, "mission"), "mission must have at least one waypoint"));
  }
  c.waypoints.clear();
  for (const proto::Waypoint& w : m.waypoints()) {
    c.waypoints.push_back(PathWaypoint{Eigen::Vector3d(w.north_m(), w.east_m(), w.down_m()), w.yaw_rad()});
  }
  if (m.acceptance_radius_m() > 0.0) c.acceptance_radius_m = m.acceptance_radius_m();
  if (!(std::isfinite(m.acceptance_radius_m()) && m.acceptance_radius_m() >= 0.0)) {
    return fail(semantic(at.locate({Step{"mission", -1}}, "acceptance_radius_m"),
                         "mission.acceptance_radius_m must be a finite distance >= 0 m (0 = 0.05 m)"));
  }
  c.timeout = launch::mission_timeout(m);
  if (!(c.timeout.count() > 0.0) || !std::isfinite(c.timeout.count())) {
    return fail(semantic(at.locate({Step{"mission", -1}}, "timeout_s"), "mission.timeout_s must be > 0 s"));
  }
  return {};
}

void plant_from_launch(SimConfig& c, const proto::Launch& g) {
  c.physics_step = launch::physics_step(g.plant());
  c.wind.mean_N_m_s = plant::mean_wind_N(g.plant().wind_mean_m_s(), g.plant().wind_toward_deg());
  c.wind.gust_std_m_s = g.plant().wind_gust_m_s();
  c.alignment = launch::alignment(g.lockstep());  // the runtime's plant aligns as long (idl/launch.proto)
}

// Attack plan: the model simulates the first attack that acts on the vehicle — the worst-case control attack
// (§VI-D) or another kind of the attack library (attack_library.hpp); the other kinds target the runtime
// and are exercised by the multi-process security tests.
void attack_from_launch(AttackConfig& attack, const proto::Launch& g) {
  attack.enabled = AttackSwitch::Off;
  if (!g.attack().enabled()) return;
  for (const proto::Attack& a : g.attack().attacks()) {
    if (const auto law = attack_law_from_number(a.kind())) {
      attack = AttackConfig{.enabled = AttackSwitch::On,
                            .law = *law,
                            .magnitude = a.magnitude(),
                            .start = Seconds{a.start_s()},
                            .max_windows = a.max_windows()};
      return;
    }
  }
}

// The control design must succeed on these numbers: report a failure where the number was written.
Filled control_design_fits(const SimConfig& c, const TextLocations& at) {
  auto d = design_control(control_spec_for(c));
  if (d) return {};
  SourceLocation where = at.file_only();
  switch (d.error().kind) {
    case DesignError::Limits: where = sr_at(at, "restricted_limit_fraction"); break;
    case DesignError::Ellipsoid: where = sr_at(at, "box"); break;
    case DesignError::Vehicle:
    case DesignError::Model:
    case DesignError::MissionLqr:
    case DesignError::SafetyLqr:
      where = at.locate({}, "plant");
      break;
  }
  return fail(semantic(where, d.error().to_string()));
}

}  // namespace

Result<SimConfig, LoadError> config_from_launch(const launch::LoadedLaunch& loaded, const SimOverrides& overrides) {
  const proto::Launch& g = loaded.graph;
  const TextLocations& at = loaded.locations;
  SimConfig c = SimConfig::defaults();
  c.graph_name = g.name();
  c.seed = overrides.seed.value_or(g.seed());
  if (Filled f = sr_from_launch(c, g, at, overrides.sr); !f) return fail(std::move(f.error()));
  if (Filled f = mission_from_launch(c, g.mission(), at); !f) return fail(std::move(f.error()));
  plant_from_launch(c, g);
  attack_from_launch(c.attack, g);
  if (overrides.attack) c.attack.enabled = *overrides.attack;
  if (overrides.t_cp) c.t_cp = *overrides.t_cp;
  if (overrides.t_rb) c.t_rb = *overrides.t_rb;
  c.stop_after_attacks = g.stop_after_attacks();
  if (Filled f = control_design_fits(c, at); !f) return fail(std::move(f.error()));
  return c;
}

}  // namespace rejuv::flight
