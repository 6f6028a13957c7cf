// The checks of a parsed launch graph (docs/design.md §1, §10; every rule idl/launch.proto states): texts, header,
// services, plant, DDS, SR parameters, sandbox limits, lockstep timing, mission and attack plan, and the policy
// file it names. Each refusal is a semantic LoadError at the field's file:line:column with what was expected.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <tuple>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "validate.hpp"

namespace rejuv::launch::detail {

namespace {

using Check = Result<void, LoadError>;
using Step = TextLocations::Step;

// A semantic error at `where`.
LoadError error(SourceLocation where, std::string message) {
  return semantic_error(std::move(where), std::move(message));
}

// What a launch field's number is measured in, for the message and for the hint of a value in another unit.
enum class Unit : std::uint8_t { Seconds, Fraction, MetresPerSecond };

// The plausible range of a launch field [min, max] in its unit (min excluded when `min_open`): narrower than what
// the kernel could represent, so that a value written in another unit (ms for s, % for a fraction, km/h for m/s)
// is refused at load instead of flying. Each bound says where it comes from where the range is declared.
struct Plausible {
  std::string_view field;   // as written in the file, e.g. "sr.t_mc_s"
  std::string_view symbol;  // as the paper names it, e.g. "T_MC"
  Unit unit;
  double min;
  bool min_open;
  double max;
};

// The refusal of `v` outside `p`, with a "did you mean" when v in the likely other unit is in range; none when in
// range.
std::optional<std::string> implausible(const Plausible& p, double v) {
  const auto inside = [&](double x) { return (p.min_open ? x > p.min : x >= p.min) && x <= p.max; };
  if (inside(v)) return std::nullopt;
  const std::string range = num(p.min) + (p.min_open ? " < " : " ≤ ") + std::string(p.symbol) + " ≤ " + num(p.max);
  std::string out = std::string(p.field) + ": " + num(v);
  switch (p.unit) {
    case Unit::Seconds:
      out += " is " + num(v) + " s; " + std::string(p.symbol) + " is seconds (" + range + " s)";
      if (v > p.max && inside(v / 1000.0)) out += "; did you mean " + num(v / 1000.0) + " (" + num(v) + " ms)?";
      break;
    case Unit::Fraction:
      out += " is out of range; " + std::string(p.symbol) + " is a fraction (" + range + ")";
      if (v >= 2.0 && inside(v / 100.0)) out += "; did you mean " + num(v / 100.0) + " (" + num(v) + " %)?";
      break;
    case Unit::MetresPerSecond:
      out += " is " + num(v) + " m/s; " + std::string(p.symbol) + " is metres per second (" + range + " m/s)";
      if (v > p.max && inside(v / 3.6)) out += "; did you mean " + num(v / 3.6) + " (" + num(v) + " km/h)?";
      break;
  }
  return out;
}

// The plausible range of an SR time or fraction is its key's range (rejuv/core/graph_values.hpp says where each
// bound comes from), in the file's unit.
Plausible plausible(const graph_values::Key<Nanos>& key) {
  return Plausible{key.name, key.symbol, Unit::Seconds, to_seconds(key.range.min).count(), key.range.min_open,
                   to_seconds(key.range.max).count()};
}
Plausible plausible(const graph_values::Key<double>& key) {
  return Plausible{key.name, key.symbol, Unit::Fraction, key.range.min, key.range.min_open, key.range.max};
}
// Wind on the vehicle model (plant, docs/design.md §9): its thrust holds a few m/s; beyond 30 m/s (a storm) no mission of
// a small quadrotor is flown, so a larger number is another unit (km/h).
constexpr double kMaxWindMS = 30.0;
constexpr double kMaxMissionS = 86400.0;

// Validates one parsed graph; the first problem found is returned (the user fixes and reruns).
class Validator {
 public:
  Validator(const proto::Launch& g, const TextLocations& locs, const std::filesystem::path& path)
      : g_(g), locs_(locs), path_(path) {}

  Result<std::filesystem::path, LoadError> run() {
    for (Check c : {check_text(), check_header(), check_services(), check_plant(), check_dds(), check_sr(),
                    check_limits(), check_realtime(), check_lockstep(), check_mission(), check_attack(),
                    check_network(), check_hosts(g_, locs_), check_link_lease(g_, locs_, path_)}) {
      if (!c) {
        return fail(std::move(c.error()));
      }
    }
    return resolve_policy();
  }

 private:
  // Where a field was written (TextLocations::locate already falls back to the enclosing message).
  [[nodiscard]] SourceLocation at(std::initializer_list<Step> path, std::string_view field,
                                  int index = -1) const {
    return locs_.locate(path, field, index);
  }

  // Every text of the graph is valid UTF-8 (protobuf's text parser does not check proto3 strings).
  Check check_text() const {
    const auto utf8 = [&](const std::string& v, SourceLocation where, std::string_view what) -> Check {
      if (!is_utf8(v)) {
        return fail(error(std::move(where), std::string(what) + " is not valid UTF-8"));
      }
      return {};
    };
    const auto params = [&](const auto& list, std::string_view owner, const auto& locate) -> Check {
      for (int p = 0; p < list.size(); ++p) {
        if (Check c = utf8(list[p].name(), locate(p, "name"), std::string(owner) + " parameter name"); !c) return c;
        if (Check c = utf8(list[p].text(), locate(p, "text"), std::string(owner) + " parameter text"); !c) return c;
      }
      return {};
    };
    if (Check c = utf8(g_.name(), at({}, "name"), "the graph's `name`"); !c) return c;
    if (Check c = utf8(g_.policy(), at({}, "policy"), "`policy`"); !c) return c;
    for (int i = 0; i < g_.services_size(); ++i) {
      const proto::ServiceSpec& s = g_.services(i);
      if (Check c = utf8(s.name(), at({{"services", i}}, "name"), "a service `name`"); !c) return c;
      if (Check c = utf8(s.executable(), at({{"services", i}}, "executable"), "an `executable`"); !c) return c;
      for (int u = 0; u < s.uses_size(); ++u) {
        if (Check c = utf8(s.uses(u).object(), at({{"services", i}, {"uses", u}}, "object"), "a used `object`"); !c) {
          return c;
        }
        if (Check c = utf8(s.uses(u).rights(), at({{"services", i}, {"uses", u}}, "rights"), "`rights`"); !c) return c;
      }
      if (Check c = params(s.params(), "a service",
                           [&](int p, std::string_view f) { return at({{"services", i}, {"params", p}}, f); });
          !c) {
        return c;
      }
    }
    if (Check c = utf8(g_.plant().executable(), at({{"plant", -1}}, "executable"), "the plant's `executable`"); !c) {
      return c;
    }
    if (Check c = params(g_.plant().params(), "a plant",
                         [&](int p, std::string_view f) { return at({{"plant", -1}, {"params", p}}, f); });
        !c) {
      return c;
    }
    if (Check c = utf8(g_.dds().config(), at({{"dds", -1}}, "config"), "`dds.config`"); !c) return c;
    for (int b = 0; b < g_.dds().bridges_size(); ++b) {
      const proto::Bridge& br = g_.dds().bridges(b);
      if (Check c = utf8(br.topic(), at({{"dds", -1}, {"bridges", b}}, "topic"), "a bridge `topic`"); !c) return c;
      if (Check c = utf8(br.dds_name(), at({{"dds", -1}, {"bridges", b}}, "dds_name"), "a `dds_name`"); !c) return c;
    }
    for (int a = 0; a < g_.attack().attacks_size(); ++a) {
      if (Check c = utf8(g_.attack().attacks(a).service(), at({{"attack", -1}, {"attacks", a}}, "service"),
                         "an attack's `service`");
          !c) {
        return c;
      }
    }
    if (Check c = utf8(g_.network().bind_address(), at({{"network", -1}}, "bind_address"), "`network.bind_address`");
        !c) {
      return c;
    }
    return utf8(g_.network().object(), at({{"network", -1}}, "object"), "`network.object`");
  }

  // The gate's signing key, if any (docs/mavlink.md "Signing"): well-formed, and a key file kept secret.
  Check check_network() const {
    auto key = signing_key(g_.network(), path_);
    if (!key) return fail(error(at({{"network", -1}}, key.error().field), key.error().message));
    if (const std::string& a = g_.network().ground_address(); !a.empty() && !ground_address(a)) {
      return fail(error(at({{"network", -1}}, "ground_address"),
                        "`network.ground_address`: expected an IPv4 address and a port, e.g. \"127.0.0.1:14550\", got \"" + a + "\""));
    }
    return {};
  }

  Check check_header() const {
    // proto3 enums are open: a number the schema does not name parses; refuse it where it was written.
    if (!proto::ClockMode_IsValid(g_.clock())) {
      return fail(error(at({}, "clock"), "unknown `clock` " + std::to_string(g_.clock()) +
                                             ": expected LOCKSTEP or REALTIME"));
    }
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
    const double rate = p.physics_rate_hz();
    if (!std::isfinite(rate) || rate < 0.0 ||
        (rate != 0.0 && (rate < defaults::kMinPhysicsRateHz || rate > defaults::kMaxPhysicsRateHz))) {
      return fail(error(at({{"plant", -1}}, "physics_rate_hz"),
                        "plant.physics_rate_hz must be " + num(defaults::kMinPhysicsRateHz) + " to " +
                            num(defaults::kMaxPhysicsRateHz) + " Hz (0 = default " +
                            num(defaults::kPhysicsRateHz) + "), got " + num(rate)));
    }
    if (!std::isfinite(p.wind_mean_m_s()) || p.wind_mean_m_s() < 0.0) {
      return fail(
          error(at({{"plant", -1}}, "wind_mean_m_s"),
                "plant.wind_mean_m_s must be a finite speed >= 0 m/s, got " + num(p.wind_mean_m_s())));
    }
    if (auto why = implausible({"plant.wind_mean_m_s", "wind", Unit::MetresPerSecond, 0.0, false, kMaxWindMS},
                               p.wind_mean_m_s())) {
      return fail(error(at({{"plant", -1}}, "wind_mean_m_s"), *why));
    }
    if (!std::isfinite(p.wind_toward_deg()) || p.wind_toward_deg() < 0.0 || p.wind_toward_deg() >= 360.0) {
      return fail(error(at({{"plant", -1}}, "wind_toward_deg"),
                        "plant.wind_toward_deg must be in [0, 360) degrees clockwise from north (90 = toward "
                        "east), got " + num(p.wind_toward_deg())));
    }
    if (!std::isfinite(p.wind_gust_m_s()) || p.wind_gust_m_s() < 0.0) {
      return fail(
          error(at({{"plant", -1}}, "wind_gust_m_s"),
                "plant.wind_gust_m_s must be a finite intensity >= 0 m/s, got " + num(p.wind_gust_m_s())));
    }
    if (auto why = implausible({"plant.wind_gust_m_s", "gust", Unit::MetresPerSecond, 0.0, false, kMaxWindMS},
                               p.wind_gust_m_s())) {
      return fail(error(at({{"plant", -1}}, "wind_gust_m_s"), *why));
    }
    return {};
  }

  Check check_lockstep() const {
    if (!g_.has_lockstep()) {
      return {};
    }
    const proto::LockstepTiming& l = g_.lockstep();
    const auto loc = [&](std::string_view field) { return at({{"lockstep", -1}}, field); };
    for (const auto& [v, f] : {std::pair{l.checkpoint_charge_ms(), "checkpoint_charge_ms"},
                               {l.rollback_charge_ms(), "rollback_charge_ms"}}) {
      if (!std::isfinite(v) || v < 0.0 || v > defaults::kMaxChargeMs) {
        return fail(error(loc(f), "lockstep." + std::string(f) + " must be 0 to " + num(defaults::kMaxChargeMs) +
                                      " ms, got " + num(v)));
      }
    }
    if (const double v = l.catch_up_charge_us_per_sample();
        !std::isfinite(v) || v < 0.0 || v > defaults::kMaxCatchUpChargeUs) {
      return fail(error(loc("catch_up_charge_us_per_sample"), "lockstep.catch_up_charge_us_per_sample must be 0 to " +
                                                                  num(defaults::kMaxCatchUpChargeUs) + " µs, got " + num(v)));
    }
    // The plant's --align-s bound; a value in ms (20000 for 20 s) gets a hint.
    if (std::isfinite(l.alignment_s()) && l.alignment_s() > defaults::kMaxAlignmentS) {
      return fail(error(loc("alignment_s"),
                        *implausible({"lockstep.alignment_s", "alignment", Unit::Seconds, 0.0, false,
                                      defaults::kMaxAlignmentS},
                                     l.alignment_s())));
    }
    if (!std::isfinite(l.alignment_s()) || l.alignment_s() < 0.0 || l.alignment_s() > defaults::kMaxAlignmentS) {
      return fail(error(loc("alignment_s"), "lockstep.alignment_s must be 0 to " + num(defaults::kMaxAlignmentS) +
                                                " s, got " + num(l.alignment_s())));
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
      if (!proto::BridgeDirection_IsValid(b.direction())) {
        return fail(error(at({{"dds", -1}, {"bridges", i}}, "direction"),
                          "unknown bridge `direction` " + std::to_string(b.direction()) +
                              ": expected BRIDGE_OUT or BRIDGE_IN"));
      }
      // One bridge per topic: IN and OUT on the same topic would echo the kernel's own publications.
      if (!topics.insert(b.topic()).second) {
        return fail(error(at({{"dds", -1}, {"bridges", i}}, "topic"),
                          "topic \"" + b.topic() + "\" is bridged twice: one bridge per topic"));
      }
      if (!dds_names.insert(dds_name(d, b)).second) {
        return fail(error(at({{"dds", -1}, {"bridges", i}}, "dds_name"),
                          "DDS name \"" + dds_name(d, b) + "\" is used by two bridges"));
      }
    }
    return {};
  }

  // The real-time plan (docs/realtime.md): SCHED_FIFO priorities 1…99, every service's below the kernel's (the
  // kernel routes the chain and fires the rollback that ends an attack: nothing it supervises may preempt it).
  Check check_realtime() const {
    const proto::RealtimePlan& p = g_.realtime();
    const auto where = [&](std::string_view field) { return at({{"realtime", -1}}, field); };
    const std::uint32_t kernel = realtime_values(p).kernel_priority;
    if (p.has_kernel_priority() && (kernel < 2 || kernel > 99)) {
      return fail(error(where("kernel_priority"), "kernel_priority must be 2..99 (SCHED_FIFO), got " + std::to_string(kernel)));
    }
    if (p.has_plant_priority() && p.plant_priority() > 99) {
      return fail(error(where("plant_priority"),
                        "plant_priority must be 0 (SCHED_OTHER) or 1..99 (SCHED_FIFO), got " + std::to_string(p.plant_priority())));
    }
    if (p.has_max_rt_time_ms() && (p.max_rt_time_ms() < 1 || p.max_rt_time_ms() > 10000)) {
      return fail(error(where("max_rt_time_ms"), "max_rt_time_ms must be 1..10000, got " + std::to_string(p.max_rt_time_ms())));
    }
    constexpr std::uint32_t kMaxCpu = 1023;  // CPU_SETSIZE - 1
    for (const auto& [field, has, cpu] : {std::tuple{"kernel_cpu", p.has_kernel_cpu(), p.kernel_cpu()},
                                          std::tuple{"plant_cpu", p.has_plant_cpu(), p.plant_cpu()}}) {
      if (has && cpu > kMaxCpu) {
        return fail(error(where(field), std::string(field) + " must be 0..1023, got " + std::to_string(cpu)));
      }
    }
    for (int i = 0; i < g_.services_size(); ++i) {
      const proto::ServiceSpec& s = g_.services(i);
      if (s.has_cpu() && s.cpu() > kMaxCpu) {
        return fail(error(at({{"services", i}}, "cpu"),
                          "cpu of '" + s.name() + "' must be 0..1023, got " + std::to_string(s.cpu())));
      }
      if (s.rt_priority() != 0 && s.rt_priority() >= kernel) {
        return fail(error(at({{"services", i}}, "rt_priority"),
                          "rt_priority " + std::to_string(s.rt_priority()) + " of '" + s.name() +
                              "' must be below the kernel's (realtime.kernel_priority " + std::to_string(kernel) +
                              "): a service must never preempt the kernel that rolls it back"));
      }
    }
    return {};
  }

  // Sandbox limits (docs/design.md §7 "Protection") that SR can live with: every process of a rejuvenated service —
  // the live one, an image and a spare per kept generation, and the generation being taken — counts against
  // its max_processes (RLIMIT_NPROC); below that its image fork fails at a checkpoint, so it is refused at load.
  Check check_limits() const {
    const auto where = [&](int i, std::string_view field) {
      return i < 0 ? at({{"sandbox_limits", -1}}, field) : at({{"services", i}, {"limits", -1}}, field);
    };
    for (int i = -1; i < g_.services_size(); ++i) {
      const proto::SandboxLimits& l = i < 0 ? g_.sandbox_limits() : g_.services(i).limits();
      if (l.has_max_cpu_percent() && l.max_cpu_percent() != 0 && (l.max_cpu_percent() < 10 || l.max_cpu_percent() > 6400)) {
        return fail(error(where(i, "max_cpu_percent"),
                          "max_cpu_percent must be 0 (no limit) or 10..6400 (% of one CPU; the kernel's smallest quota is "
                          "1 ms per 10 ms), got " + std::to_string(l.max_cpu_percent())));
      }
      if (l.has_max_publications_per_s() &&
          (l.max_publications_per_s() < 1 || l.max_publications_per_s() > defaults::kMaxSandboxPublicationsPerS)) {
        return fail(error(where(i, "max_publications_per_s"),
                          "max_publications_per_s must be 1..1000000 (publications per second of kernel time), got " +
                              std::to_string(l.max_publications_per_s())));
      }
      if (l.has_max_open_files() && l.max_open_files() < defaults::kMinSandboxOpenFiles) {
        return fail(error(where(i, "max_open_files"), "max_open_files must be at least " +
                                                          std::to_string(defaults::kMinSandboxOpenFiles) +
                                                          " (a service's channel, pagemap and image files), got " +
                                                          std::to_string(l.max_open_files())));
      }
    }
    if (!g_.sr().enabled()) return {};
    const std::uint32_t k = keep_generations(g_.sr());
    const std::uint32_t needed = 1 + 2 * (k + 1);
    for (int i = 0; i < g_.services_size(); ++i) {
      const proto::ServiceSpec& s = g_.services(i);
      if (!rejuvenate(s)) continue;
      const SandboxLimitValues v = sandbox_limits(g_, s);
      if (v.max_processes >= needed) continue;
      const int from = s.limits().has_max_processes() ? i : -1;
      return fail(error(where(from, "max_processes"),
                        "max_processes " + std::to_string(v.max_processes) + " of '" + s.name() + "' is too low for keep_generations " +
                            std::to_string(k) + ": a rejuvenated service needs " + std::to_string(needed) +
                            " processes (the live one, an image and a spare for each of the " + std::to_string(k + 1) +
                            " generations of a checkpoint)"));
    }
    return {};
  }

  Check check_sr() const {
    if (!g_.sr().enabled()) {
      return {};  // parameters of a disabled scheme are not used (rejuv run --no-sr)
    }
    const proto::SrParams& sr = g_.sr();
    // The check period's own bounds (> 0, ≥ 1 µs) first: below them its range would say less.
    for (Check c : {check_sr_finite(sr), check_sr_intervals(sr), check_sr_check_period(sr), check_sr_plausible(sr),
                    check_sr_levels(sr),
                    check_sr_duration_bounds(sr), check_sr_keep_generations(sr), check_sr_box(sr),
                    check_sr_restricted_limits(sr), check_sr_ekf_rearm(sr)}) {
      if (!c) {
        return c;
      }
    }
    return {};
  }

  [[nodiscard]] SourceLocation sr_at(std::string_view field) const { return at({{"sr", -1}}, field); }
  // Where the field of a graph-wide key was written: "sr.box.angle_rad" at sr { box { angle_rad } }.
  [[nodiscard]] SourceLocation key_at(std::string_view name) const {
    const std::string_view field = graph_values::field_of(name);
    for (std::string_view block : {"box", "ekf_rearm"}) {
      if (name.starts_with("sr." + std::string(block) + ".")) return at({{"sr", -1}, {block, -1}}, field);
    }
    return sr_at(field);
  }

  Check check_sr_finite(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    for (const auto& [v, name] : {std::pair{sr.t_mc_s(), gv::kTmc.name},
                                  {sr.t_est_s(), gv::kTest.name},
                                  {sr.rho_m(), gv::kRhoM.name},
                                  {sr.rho_s(), gv::kRhoS.name},
                                  {sr.t_min_s(), gv::kTmin.name},
                                  {sr.check_period_s(), gv::kCheckPeriod.name},
                                  {sr.restricted_limit_fraction(), gv::kRestrictedLimitFraction.name}}) {
      if (!std::isfinite(v)) {
        return fail(error(key_at(name), std::string(name) + " must be a finite number"));
      }
    }
    return {};
  }

  // "sr.t_mc_s (T_MC)": how a message names a key.
  template <class T>
  static std::string named(const graph_values::Key<T>& key) {
    return std::string(key.name) + " (" + std::string(key.symbol) + ")";
  }

  // T_MC, T_est and t_min (§II).
  Check check_sr_intervals(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    // §II: MC must last a positive T_MC before RB, or the vehicle never flies its mission.
    if (sr.t_mc_s() <= 0.0) {
      return fail(error(key_at(gv::kTmc.name), named(gv::kTmc) + " must be > 0 s, got " + num(sr.t_mc_s())));
    }
    // §II: the safety controller needs a positive T_est to bring x̂ back into E(ρ_s) before (1) is checked.
    if (sr.t_est_s() <= 0.0) {
      return fail(error(key_at(gv::kTest.name), named(gv::kTest) + " must be > 0 s, got " + num(sr.t_est_s())));
    }
    if (sr.t_min_s() < 0.0) {
      return fail(error(key_at(gv::kTmin.name), named(gv::kTmin) + " must be >= 0 s, got " + num(sr.t_min_s())));
    }
    return {};
  }

  // Each SR time and fraction in its key's range, with a hint when the value looks like another unit
  // (`t_mc_s: 200` meant as ms).
  Check check_sr_plausible(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    const auto check = [&](const Plausible& p, double v) -> Check {
      if (auto why = implausible(p, v)) return fail(error(key_at(p.field), *why));
      return {};
    };
    if (Check c = check(plausible(gv::kTmc), sr.t_mc_s()); !c) return c;
    if (Check c = check(plausible(gv::kTest), sr.t_est_s()); !c) return c;
    if (Check c = check(plausible(gv::kTmin), sr.t_min_s()); !c) return c;
    if (sr.has_check_period_s()) {
      if (Check c = check(plausible(gv::kCheckPeriod), sr.check_period_s()); !c) return c;
    }
    // A fraction above 1 (0.1 written as 10 %); at or below 0 check_sr_levels and check_sr_restricted_limits say
    // what the level must satisfy.
    for (const auto& [key, v] : {std::pair{&gv::kRhoM, sr.rho_m()}, std::pair{&gv::kRhoS, sr.rho_s()},
                                 std::pair{&gv::kRestrictedLimitFraction, sr.restricted_limit_fraction()}}) {
      if (v <= 1.0) continue;
      if (Check c = check(plausible(*key), v); !c) return c;
    }
    return {};
  }

  // §IV-A: E(ρ_s) ⊂ E(ρ_M) ⊆ the safety set ‖e‖_P ≤ 1 (P scaled to the state box, docs/design.md §9).
  Check check_sr_levels(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    if (!(sr.rho_s() > 0.0 && sr.rho_s() < sr.rho_m())) {
      return fail(error(key_at(gv::kRhoS.name),
                        std::string(gv::kRhoS.name) + " and " + std::string(gv::kRhoM.name) +
                            " must satisfy 0 < rho_s < rho_m (§IV-A), got rho_s = " + num(sr.rho_s()) +
                            ", rho_m = " + num(sr.rho_m())));
    }
    if (!gv::in_range(gv::kRhoM, sr.rho_m())) {
      return fail(error(key_at(gv::kRhoM.name),
                        std::string(gv::kRhoM.name) + " must be <= " + num(gv::kRhoM.range.max) +
                            ": E(rho_M) lies inside the safety set ||e||_P <= 1, got " + num(sr.rho_m())));
    }
    return {};
  }

  Check check_sr_check_period(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    const std::string name(gv::kCheckPeriod.name);
    if (sr.has_check_period_s() && sr.check_period_s() <= 0.0) {
      return fail(error(key_at(name), name + " must be > 0 s (omit it for the default " +
                                          num(to_seconds(gv::kCheckPeriod.fallback).count()) + " s), got " +
                                          num(sr.check_period_s())));
    }
    const double min_s = to_seconds(gv::kCheckPeriod.range.min).count();
    if (sr.has_check_period_s() && sr.check_period_s() < min_s) {
      return fail(error(key_at(name), name + " must be at least " + num(min_s) +
                                          " s (the kernel's timers count ns), got " + num(sr.check_period_s())));
    }
    return {};
  }

  // Durations beyond the bound overflow the kernel's ns clock or never elapse.
  Check check_sr_duration_bounds(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    for (const auto& [v, name] : {std::pair{sr.t_mc_s(), gv::kTmc.name},
                                  {sr.t_est_s(), gv::kTest.name},
                                  {sr.t_min_s(), gv::kTmin.name},
                                  {sr.check_period_s(), gv::kCheckPeriod.name}}) {
      if (v > defaults::kMaxDurationS) {
        return fail(error(key_at(name), std::string(name) + " must be at most " + num(defaults::kMaxDurationS) +
                                            " s, got " + num(v)));
      }
    }
    return {};
  }

  Check check_sr_keep_generations(const proto::SrParams& sr) const {
    const auto& key = graph_values::kKeepGenerations;
    if (sr.has_keep_generations() && !graph_values::in_range(key, sr.keep_generations())) {
      return fail(error(key_at(key.name),
                        std::string(key.name) + " must be " + std::to_string(key.range.min) + " to " +
                            std::to_string(key.range.max) +
                            " (each generation keeps a frozen process of every rejuvenated service; omit it "
                            "for the default " +
                            std::to_string(key.fallback) + "), got " + std::to_string(sr.keep_generations())));
    }
    return {};
  }

  Check check_sr_box(const proto::SrParams& sr) const {
    namespace gv = graph_values;
    const proto::StateBox& box = sr.box();
    for (const auto& [v, key] : {std::pair{box.position_m(), &gv::kBoxPosition},
                                 {box.velocity_m_s(), &gv::kBoxVelocity},
                                 {box.angle_rad(), &gv::kBoxAngle},
                                 {box.rate_rad_s(), &gv::kBoxRate}}) {
      if (!gv::in_range(*key, v)) {
        return fail(error(key_at(key->name),
                          std::string(key->name) +
                              " must be a finite half-width > 0 (it scales P, docs/design.md §9), got " + num(v)));
      }
    }
    return {};
  }

  Check check_sr_restricted_limits(const proto::SrParams& sr) const {
    const auto& key = graph_values::kRestrictedLimitFraction;
    const double frac = sr.restricted_limit_fraction();
    if (!graph_values::in_range(key, frac)) {
      return fail(error(key_at(key.name), std::string(key.name) + " (" + std::string(key.symbol) +
                                              " as a fraction of U, §III) must be in (0, 1], got " + num(frac)));
    }
    return {};
  }

  Check check_sr_ekf_rearm(const proto::SrParams& sr) const {
    for (const RearmField& f : ekf_rearm_fields(sr.ekf_rearm())) {
      if (f.is_switch) continue;
      if (!graph_values::in_range(*f.key, f.value)) {
        return fail(error(key_at(f.key->name),
                          std::string(f.key->name) + " must be a finite 1-sigma > 0, got " + num(f.value)));
      }
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
      for (const auto& [v, f] : {std::pair{w.north_m(), "north_m"}, {w.east_m(), "east_m"}, {w.down_m(), "down_m"}}) {
        if (std::abs(v) > defaults::kMaxWaypointOffsetM) {
          return fail(error(at({{"mission", -1}, {"waypoints", i}}, f),
                            "waypoint " + std::to_string(i) + ": " + f + " must be within ±" +
                                num(defaults::kMaxWaypointOffsetM) + " m of the origin, got " + num(v)));
        }
      }
      // NED: down_m > 0 is under the ground plane the plant stands on (an altitude of 3 m is down_m: -3).
      if (w.down_m() > 0.0) {
        return fail(error(at({{"mission", -1}, {"waypoints", i}}, "down_m"),
                          "waypoint " + std::to_string(i) + " is below the ground: down_m must be <= 0 (NED; "
                          "an altitude of 3 m is down_m: -3), got " + num(w.down_m())));
      }
    }
    if (!std::isfinite(m.acceptance_radius_m()) || m.acceptance_radius_m() <= 0.0) {
      return fail(error(at({{"mission", -1}}, "acceptance_radius_m"),
                        "mission.acceptance_radius_m must be > 0 m, got " + num(m.acceptance_radius_m())));
    }
    if (m.has_timeout_s() &&
        (!std::isfinite(m.timeout_s()) || m.timeout_s() <= 0.0 || m.timeout_s() > defaults::kMaxDurationS)) {
      return fail(error(at({{"mission", -1}}, "timeout_s"),
                        "mission.timeout_s must be > 0 s and at most " + num(defaults::kMaxDurationS) +
                            " s (leave it out to derive it from the path), got " + num(m.timeout_s())));
    }
    // A mission of the vehicle model lasts minutes (launch/: 60–600 s); a day bounds it, and a larger number is ms.
    if (m.has_timeout_s()) {
      if (auto why = implausible({"mission.timeout_s", "timeout", Unit::Seconds, 0.0, true, kMaxMissionS}, m.timeout_s())) {
        return fail(error(at({{"mission", -1}}, "timeout_s"), *why));
      }
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
      if (!proto::AttackKind_IsValid(a.kind())) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "kind"),
                          "unknown attack `kind` " + std::to_string(a.kind()) +
                              ": expected a name of idl/launch.proto AttackKind, e.g. WORST_CASE_CONTROL"));
      }
      const proto::ServiceSpec* target = find_service(g_, a.service());
      if (target == nullptr) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "service"),
                          a.service().empty()
                              ? std::string("attack without a `service` to compromise")
                              : "attack names service \"" + a.service() + "\", which is not in the graph"));
      }
      // docs/design.md §9: a kind the service has no hook for would do nothing at run time, while `rejuv sim`
      // models it anyway: refused, so that model and runtime never disagree without a word.
      if (const auto hooks = attack_hooks_of(target->executable()); hooks) {
        if (std::find(hooks->begin(), hooks->end(), a.kind()) == hooks->end()) {
          return fail(
              error(at({{"attack", -1}, {"attacks", i}}, "kind"),
                    "service \"" + a.service() + "\" (" + target->executable() + ") has no hook for " +
                        proto::AttackKind_Name(a.kind()) + "; the kinds it supports: " + kind_list(*hooks) +
                        (a.kind() == proto::CUSTOM ? " (CUSTOM is for a service of your own that installs "
                                                     "the SDK's hook, rejuv/sdk/attack_hook.hpp)"
                                                   : "")));
        }
      }
      if (!std::isfinite(a.start_s()) || a.start_s() < 0.0) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "start_s"),
                          "attack start_s must be >= 0 s, got " + num(a.start_s())));
      }
      if (!std::isfinite(a.magnitude()) || a.magnitude() < 0.0 || a.magnitude() > 1e6) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "magnitude"),
                          "attack magnitude must be in [0, 1e6] (0 = the kind's default), got " + num(a.magnitude())));
      }
      // FLOOD_BROKER's magnitude: publications per tick of a sustained flood (0 = one burst per window).
      if (a.kind() == proto::FLOOD_BROKER && (a.magnitude() != std::floor(a.magnitude()) || a.magnitude() > 100000.0)) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "magnitude"),
                          "FLOOD_BROKER takes a whole count in [0, 100000] as its magnitude (publications per "
                          "tick; 0 = one burst of 10000 per window), got " + num(a.magnitude())));
      }
      // OOM_IMAGES's magnitude: MiB touched at boot (1.5× that in each window).
      if (a.kind() == proto::OOM_IMAGES && (a.magnitude() != std::floor(a.magnitude()) || a.magnitude() > 65536.0)) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "magnitude"),
                          "OOM_IMAGES takes whole MiB in [0, 65536] as its magnitude (0 = 600 MiB), got " +
                              num(a.magnitude())));
      }
      // The attacks on rollback itself (18…27) take a count of processes or threads.
      const bool counted = a.kind() >= proto::SIGIO_IMAGES && a.kind() <= proto::PAGEMAP_FRAMES;
      if (counted && (a.magnitude() != std::floor(a.magnitude()) || a.magnitude() > 1000.0)) {
        return fail(error(at({{"attack", -1}, {"attacks", i}}, "magnitude"),
                          proto::AttackKind_Name(a.kind()) +
                              " takes a whole count in [0, 1000] as its magnitude (0 = its default), got " +
                              num(a.magnitude())));
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
      // Absolute: a copied launch file's relative path is read from where the copy is, which the message shows.
      const std::filesystem::path shown = std::filesystem::absolute(p, ec).lexically_normal();
      return fail(error(at({}, "policy"), "policy file \"" + g_.policy() + "\" (resolved to " +
                                              (shown.empty() ? p : shown).string() +
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

}  // namespace

Result<LoadedLaunch, LoadError> validate(proto::Launch graph, TextLocations locs,
                                         const std::filesystem::path& path) {
  auto policy = Validator(graph, locs, path).run();
  if (!policy) {
    return fail(std::move(policy.error()));
  }
  return LoadedLaunch{std::move(graph), std::move(locs), path, std::move(*policy), {}};
}

}  // namespace rejuv::launch::detail
