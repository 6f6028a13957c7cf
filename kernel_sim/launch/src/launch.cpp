#include "rejuv/launch/launch.hpp"

#include <cmath>
#include <cstdio>
#include <set>
#include <system_error>

#include "rejuv/core/vocabulary.hpp"

namespace rejuv::launch {

namespace {

using Check = Result<void, LoadError>;
using Step = TextLocations::Step;

// "0.1" rather than "0.100000": numbers in messages are echoed the way users write them.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Names are shared with the policy and appear in boot info and audit output: keep them plain.
bool is_plain_name(std::string_view s) {
  if (s.empty()) {
    return false;
  }
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.';
    if (!ok) {
      return false;
    }
  }
  return true;
}

// Validates one parsed graph; the first problem found is returned (the user fixes and reruns).
class Validator {
 public:
  Validator(const proto::Launch& g, const TextLocations& locs, const std::filesystem::path& path)
      : g_(g), locs_(locs), path_(path) {}

  Result<std::filesystem::path, LoadError> run() {
    for (Check c : {check_header(), check_services(), check_plant(), check_dds(), check_sr(), check_mission(),
                    check_attack()}) {
      if (!c) {
        return fail(std::move(c.error()));
      }
    }
    return resolve_policy();
  }

 private:
  // A semantic error at `where` (TextLocations::locate already falls back to the enclosing message).
  [[nodiscard]] static LoadError error(SourceLocation where, std::string message) {
    return semantic_error(std::move(where), std::move(message));
  }
  [[nodiscard]] SourceLocation at(std::initializer_list<Step> path, std::string_view field,
                                  int index = -1) const {
    return locs_.locate(path, field, index);
  }

  Check check_header() const {
    if (g_.name().empty()) {
      return fail(error(at({}, "name"), "missing `name`: expected name: \"<graph name>\""));
    }
    if (g_.policy().empty()) {
      return fail(error(at({}, "policy"),
                        "missing `policy`: expected the policy file, relative to this file, e.g. "
                        "policy: \"../policies/quad_sr.policy.pbtxt\""));
    }
    if (g_.services_size() == 0) {
      return fail(error(at({}, "name"), "the graph has no `services`: expected at least one"));
    }
    return {};
  }

  Check check_services() const {
    std::set<std::string_view> names;
    for (int i = 0; i < g_.services_size(); ++i) {
      const proto::ServiceSpec& s = g_.services(i);
      if (!is_plain_name(s.name())) {
        return fail(error(at({{"services", i}}, "name"),
                          s.name().empty() ? std::string("service without a `name`")
                                           : "service name \"" + s.name() +
                                                 "\" must use only letters, digits, '_', '-', '.'"));
      }
      if (!names.insert(s.name()).second) {
        return fail(error(at({{"services", i}}, "name"),
                          "duplicate service name \"" + s.name() + "\": service names are unique"));
      }
      if (s.executable().empty()) {
        return fail(
            error(at({{"services", i}}, "executable"), "service \"" + s.name() + "\" has no `executable`"));
      }
      std::set<std::string_view> used;
      for (int u = 0; u < s.uses_size(); ++u) {
        const proto::Use& use = s.uses(u);
        if (use.object().empty()) {
          return fail(error(at({{"services", i}, {"uses", u}}, "object"),
                            "`uses` entry without an `object` in service \"" + s.name() + "\""));
        }
        if (!used.insert(use.object()).second) {
          return fail(error(at({{"services", i}, {"uses", u}}, "object"),
                            "service \"" + s.name() + "\" lists \"" + use.object() +
                                "\" twice in `uses`: merge the rights into one entry"));
        }
        if (!Rights::parse(use.rights())) {
          return fail(error(at({{"services", i}, {"uses", u}}, "rights"),
                            "bad rights \"" + use.rights() + "\" for \"" + use.object() +
                                "\": expected one or more distinct letters of R, W, G"));
        }
      }
      std::set<std::string_view> params;
      for (int p = 0; p < s.params_size(); ++p) {
        const proto::Param& param = s.params(p);
        if (param.name().empty() || !params.insert(param.name()).second) {
          return fail(error(at({{"services", i}, {"params", p}}, "name"),
                            param.name().empty() ? "parameter without a `name`"
                                                 : "duplicate parameter \"" + param.name() + "\""));
        }
        if (param.value_case() == proto::Param::VALUE_NOT_SET) {
          return fail(error(at({{"services", i}, {"params", p}}, "name"),
                            "parameter \"" + param.name() + "\" has no value: expected `number` or `text`"));
        }
        if (param.value_case() == proto::Param::kNumber && !std::isfinite(param.number())) {
          return fail(error(at({{"services", i}, {"params", p}}, "number"),
                            "parameter \"" + param.name() + "\" must be a finite number"));
        }
      }
    }
    return {};
  }

  Check check_plant() const {
    if (!g_.has_plant()) {
      return {};
    }
    const proto::PlantSpec& p = g_.plant();
    if (p.executable().empty()) {
      return fail(error(at({}, "plant"), "`plant` has no `executable`"));
    }
    if (!std::isfinite(p.physics_rate_hz()) || p.physics_rate_hz() < 0.0) {
      return fail(error(at({{"plant", -1}}, "physics_rate_hz"),
                        "plant.physics_rate_hz must be a finite rate >= 0 Hz (0 = default " +
                            num(defaults::kPhysicsRateHz) + "), got " + num(p.physics_rate_hz())));
    }
    if (!std::isfinite(p.wind_mean_m_s()) || p.wind_mean_m_s() < 0.0) {
      return fail(
          error(at({{"plant", -1}}, "wind_mean_m_s"),
                "plant.wind_mean_m_s must be a finite speed >= 0 m/s, got " + num(p.wind_mean_m_s())));
    }
    if (!std::isfinite(p.wind_gust_m_s()) || p.wind_gust_m_s() < 0.0) {
      return fail(
          error(at({{"plant", -1}}, "wind_gust_m_s"),
                "plant.wind_gust_m_s must be a finite intensity >= 0 m/s, got " + num(p.wind_gust_m_s())));
    }
    return {};
  }

  Check check_dds() const {
    if (!g_.has_dds()) {
      return {};
    }
    const proto::DdsSpec& d = g_.dds();
    if (d.domain_id() > defaults::kMaxDdsDomainId) {
      return fail(error(at({{"dds", -1}}, "domain_id"), "dds.domain_id must be 0.." +
                                                            std::to_string(defaults::kMaxDdsDomainId) +
                                                            ", got " + std::to_string(d.domain_id())));
    }
    std::set<std::string_view> topics;
    std::set<std::string> dds_names;
    for (int i = 0; i < d.bridges_size(); ++i) {
      const proto::Bridge& b = d.bridges(i);
      if (b.topic().empty()) {
        return fail(error(at({{"dds", -1}, {"bridges", i}}, "topic"), "bridge without a `topic`"));
      }
      // One bridge per topic: IN and OUT on the same topic would echo the kernel's own publications.
      if (!topics.insert(b.topic()).second) {
        return fail(error(at({{"dds", -1}, {"bridges", i}}, "topic"),
                          "topic \"" + b.topic() + "\" is bridged twice: one bridge per topic"));
      }
      if (!dds_names.insert(dds_name(b)).second) {
        return fail(error(at({{"dds", -1}, {"bridges", i}}, "dds_name"),
                          "DDS name \"" + dds_name(b) + "\" is used by two bridges"));
      }
    }
    return {};
  }

  Check check_sr() const {
    if (!g_.sr().enabled()) {
      return {};  // parameters of a disabled scheme are not used (rejuv run --no-sr)
    }
    const proto::SrParams& sr = g_.sr();
    const auto loc = [&](std::string_view field) { return at({{"sr", -1}}, field); };
    const auto finite = [&](double v, std::string_view field) -> Check {
      if (!std::isfinite(v)) {
        return fail(error(loc(field), "sr." + std::string(field) + " must be a finite number"));
      }
      return {};
    };
    for (const auto& [v, f] : {std::pair{sr.t_mc_s(), "t_mc_s"},
                               {sr.t_est_s(), "t_est_s"},
                               {sr.rho_m(), "rho_m"},
                               {sr.rho_s(), "rho_s"},
                               {sr.t_min_s(), "t_min_s"},
                               {sr.check_period_s(), "check_period_s"},
                               {sr.restricted_limit_fraction(), "restricted_limit_fraction"}}) {
      if (Check c = finite(v, f); !c) {
        return c;
      }
    }
    // §II: MC must last a positive T_MC before RB, or the vehicle never flies its mission.
    if (sr.t_mc_s() <= 0.0) {
      return fail(error(loc("t_mc_s"), "sr.t_mc_s (T_MC) must be > 0 s, got " + num(sr.t_mc_s())));
    }
    if (sr.t_est_s() < 0.0) {
      return fail(error(loc("t_est_s"), "sr.t_est_s (T_est) must be >= 0 s, got " + num(sr.t_est_s())));
    }
    if (sr.t_min_s() < 0.0) {
      return fail(error(loc("t_min_s"), "sr.t_min_s (t_min) must be >= 0 s, got " + num(sr.t_min_s())));
    }
    // §IV-A: E(ρ_s) ⊂ E(ρ_M) ⊆ the safety set ‖e‖_P ≤ 1 (P scaled to the state box, DESIGN §9).
    if (!(sr.rho_s() > 0.0 && sr.rho_s() < sr.rho_m())) {
      return fail(
          error(loc("rho_s"), "sr.rho_s and sr.rho_m must satisfy 0 < rho_s < rho_m (§IV-A), got rho_s = " +
                                  num(sr.rho_s()) + ", rho_m = " + num(sr.rho_m())));
    }
    if (sr.rho_m() > 1.0) {
      return fail(error(
          loc("rho_m"),
          "sr.rho_m must be <= 1: E(rho_M) lies inside the safety set ||e||_P <= 1, got " + num(sr.rho_m())));
    }
    if (sr.has_check_period_s() && sr.check_period_s() <= 0.0) {
      return fail(error(loc("check_period_s"),
                        "sr.check_period_s must be > 0 s (omit it for the default 0.002 s), got " +
                            num(sr.check_period_s())));
    }
    if (sr.has_keep_generations() && sr.keep_generations() < 1) {
      return fail(
          error(loc("keep_generations"), "sr.keep_generations must be >= 1 (omit it for the default " +
                                             std::to_string(defaults::kKeepGenerations) + ")"));
    }
    const proto::StateBox& box = sr.box();
    for (const auto& [v, f] : {std::pair{box.position_m(), "position_m"},
                               {box.velocity_m_s(), "velocity_m_s"},
                               {box.angle_rad(), "angle_rad"},
                               {box.rate_rad_s(), "rate_rad_s"}}) {
      if (!std::isfinite(v) || v <= 0.0) {
        return fail(error(at({{"sr", -1}, {"box", -1}}, f),
                          "sr.box." + std::string(f) +
                              " must be a finite half-width > 0 (it scales P, DESIGN §9), got " + num(v)));
      }
    }
    const double frac = sr.restricted_limit_fraction();
    if (!(frac > 0.0 && frac <= 1.0)) {
      return fail(error(
          loc("restricted_limit_fraction"),
          "sr.restricted_limit_fraction (Ū as a fraction of U, §III) must be in (0, 1], got " + num(frac)));
    }
    return {};
  }

  Check check_mission() const {
    const proto::Mission& m = g_.mission();
    const int n = m.waypoints_size();
    if (n < 1 || static_cast<std::size_t>(n) > defaults::kMaxWaypoints) {
      return fail(error(n == 0
                            ? at({}, "mission")
                            : at({{"mission", -1}}, "waypoints", static_cast<int>(defaults::kMaxWaypoints)),
                        "mission must have 1.." + std::to_string(defaults::kMaxWaypoints) +
                            " waypoints, got " + std::to_string(n)));
    }
    for (int i = 0; i < n; ++i) {
      const proto::Waypoint& w = m.waypoints(i);
      for (const auto& [v, f] : {std::pair{w.north_m(), "north_m"},
                                 {w.east_m(), "east_m"},
                                 {w.down_m(), "down_m"},
                                 {w.yaw_rad(), "yaw_rad"}}) {
        if (!std::isfinite(v)) {
          return fail(error(at({{"mission", -1}, {"waypoints", i}}, f),
                            "waypoint " + std::to_string(i) + ": " + f + " must be a finite number"));
        }
      }
    }
    if (!std::isfinite(m.acceptance_radius_m()) || m.acceptance_radius_m() <= 0.0) {
      return fail(error(at({{"mission", -1}}, "acceptance_radius_m"),
                        "mission.acceptance_radius_m must be > 0 m, got " + num(m.acceptance_radius_m())));
    }
    if (!std::isfinite(m.timeout_s()) || m.timeout_s() <= 0.0) {
      return fail(error(at({{"mission", -1}}, "timeout_s"),
                        "mission.timeout_s must be > 0 s, got " + num(m.timeout_s())));
    }
    return {};
  }

  Check check_attack() const {
    const proto::AttackPlan& plan = g_.attack();
    for (int i = 0; i < plan.attacks_size(); ++i) {
      const proto::Attack& a = plan.attacks(i);
      if (a.kind() == proto::ATTACK_UNSPECIFIED) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "kind"),
                          "attack without a `kind`: expected e.g. kind: WORST_CASE_CONTROL"));
      }
      if (find_service(g_, a.service()) == nullptr) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "service"),
                          a.service().empty()
                              ? std::string("attack without a `service` to compromise")
                              : "attack names service \"" + a.service() + "\", which is not in the graph"));
      }
      if (!std::isfinite(a.start_s()) || a.start_s() < 0.0) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "start_s"),
                          "attack start_s must be >= 0 s, got " + num(a.start_s())));
      }
    }
    return {};
  }

  // The policy path is relative to the launch file (idl/launch.proto).
  Result<std::filesystem::path, LoadError> resolve_policy() const {
    std::filesystem::path p(g_.policy());
    if (p.is_relative()) {
      p = path_.parent_path() / p;
    }
    p = p.lexically_normal();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) {
      return fail(error(at({}, "policy"), "policy file \"" + g_.policy() + "\" (resolved to " + p.string() +
                                              ") does not exist or is not a regular file"));
    }
    if (g_.has_dds() && !g_.dds().config().empty()) {
      std::filesystem::path cfg(g_.dds().config());
      if (cfg.is_relative()) {
        cfg = path_.parent_path() / cfg;
      }
      if (!std::filesystem::is_regular_file(cfg, ec)) {
        return fail(
            error(at({{"dds", -1}}, "config"), "DDS config \"" + g_.dds().config() + "\" (resolved to " +
                                                   cfg.lexically_normal().string() + ") does not exist"));
      }
    }
    return p;
  }

  const proto::Launch& g_;
  const TextLocations& locs_;
  const std::filesystem::path& path_;
};

Result<LoadedLaunch, LoadError> validate(proto::Launch graph, TextLocations locs,
                                         const std::filesystem::path& path) {
  auto policy = Validator(graph, locs, path).run();
  if (!policy) {
    return fail(std::move(policy.error()));
  }
  return LoadedLaunch{std::move(graph), std::move(locs), path, std::move(*policy)};
}

}  // namespace

Result<LoadedLaunch, LoadError> load_launch(const std::filesystem::path& path) {
  proto::Launch graph;
  auto locs = load_textproto(path, graph);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return validate(std::move(graph), std::move(*locs), path);
}

Result<LoadedLaunch, LoadError> parse_launch(std::string_view text, const std::filesystem::path& as_path) {
  proto::Launch graph;
  auto locs = parse_textproto(text, as_path.string(), graph);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return validate(std::move(graph), std::move(*locs), as_path);
}

std::uint32_t keep_generations(const proto::SrParams& sr) {
  return sr.has_keep_generations() ? sr.keep_generations() : defaults::kKeepGenerations;
}
Seconds check_period(const proto::SrParams& sr) {
  return sr.has_check_period_s() ? Seconds(sr.check_period_s()) : defaults::kCheckPeriod;
}
Seconds t_mc(const proto::SrParams& sr) {
  return Seconds(sr.t_mc_s());
}
Seconds t_est(const proto::SrParams& sr) {
  return Seconds(sr.t_est_s());
}
Seconds t_min(const proto::SrParams& sr) {
  return Seconds(sr.t_min_s());
}
Seconds mission_timeout(const proto::Mission& mission) {
  return Seconds(mission.timeout_s());
}

double physics_rate_hz(const proto::PlantSpec& plant) {
  return plant.physics_rate_hz() > 0.0 ? plant.physics_rate_hz() : defaults::kPhysicsRateHz;
}
Seconds physics_step(const proto::PlantSpec& plant) {
  return Seconds(1.0 / physics_rate_hz(plant));
}

bool rejuvenate(const proto::ServiceSpec& service) {
  return service.has_rejuvenate() ? service.rejuvenate() : true;
}

std::string dds_name(const proto::Bridge& bridge) {
  return bridge.dds_name().empty() ? std::string(defaults::kDdsNamePrefix) + bridge.topic()
                                   : bridge.dds_name();
}

std::filesystem::path dds_config(const LoadedLaunch& launch, const std::filesystem::path& repo_root) {
  const std::string& cfg = launch.graph.dds().config();
  if (cfg.empty()) {
    return repo_root / defaults::kDdsConfig;
  }
  const std::filesystem::path p(cfg);
  return (p.is_relative() ? launch.path.parent_path() / p : p).lexically_normal();
}

const proto::ServiceSpec* find_service(const proto::Launch& graph, std::string_view name) {
  for (const proto::ServiceSpec& s : graph.services()) {
    if (s.name() == name) {
      return &s;
    }
  }
  return nullptr;
}

SandboxLimitValues sandbox_limits(const proto::Launch& graph, const proto::ServiceSpec& service) {
  SandboxLimitValues v;
  for (const proto::SandboxLimits* l : {&graph.sandbox_limits(), &service.limits()}) {  // the service's last
    if (l->has_max_processes()) v.max_processes = l->max_processes();
    if (l->has_max_memory_mb()) v.max_memory_mb = l->max_memory_mb();
    if (l->has_max_open_files()) v.max_open_files = l->max_open_files();
  }
  return v;
}

}  // namespace rejuv::launch
