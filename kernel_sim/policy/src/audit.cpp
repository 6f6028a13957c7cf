#include "rejuv/policy/audit.hpp"

#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/policy/hosts.hpp"

#include <algorithm>
#include <map>
#include <optional>
#include <tuple>

namespace rejuv::policy {

std::string_view to_string(Invariant invariant) {
  switch (invariant) {
    case Invariant::Timer: return "timer";
    case Invariant::Sei: return "sei";
    case Invariant::Limits: return "limits";
    case Invariant::Persistent: return "persistent";
    case Invariant::Lateral: return "lateral";
    case Invariant::Checkpoint: return "checkpoint";
    case Invariant::Mode: return "mode";
    case Invariant::Restricted: return "restricted";
    case Invariant::Controls: return "controls";
    case Invariant::Coverage: return "coverage";
    case Invariant::Hosts: return "hosts";
    case Invariant::Deny: return "deny";
  }
  return "?";
}

std::string Finding::id() const {
  if (invariant == Invariant::Deny) return "deny:" + rule;
  if (invariant == Invariant::Hosts) return "hosts:" + rule;
  return std::string(policy::to_string(invariant));
}

std::string Finding::to_string() const {
  return where.to_string() + ": violation [" + id() + "]: " + message;
}

namespace {

// What every check sees: the policy and, for graph-side checks, the launch graph (nullptr without one).
struct Context {
  const Policy& policy;
  const launch::LoadedLaunch* graph;
};

using Findings = std::vector<Finding>;

// "R-- on \"x\" to \"s\" in MC,RB": the grant in words, for messages.
std::string describe(const Policy& p, const Grant& g, ModeSet modes) {
  return "\"" + g.rights.letters() + "\" on \"" + p.object(g.object).name + "\" (" +
         std::string(to_string(p.object(g.object).kind)) + ") to \"" + p.service(g.service).name + "\" in " +
         modes.to_string();
}

ModeSet only(ModeSet set, ModeSet mask) {
  ModeSet r;
  for (const SrMode m : kAllModes) {
    if (set.has(m) && mask.has(m)) {
      r.add(m);
    }
  }
  return r;
}

constexpr ModeSet kMcOnly = ModeSet().add(SrMode::MC);
// The secure execution interval (§III, §IV-D): every mode but MC.
constexpr ModeSet kSei = ModeSet().add(SrMode::RB).add(SrMode::SC).add(SrMode::Update).add(SrMode::CP);

void add(Findings& out, Invariant inv, std::string message, SourceLocation where) {
  out.push_back(Finding{inv, {}, std::move(message), std::move(where)});
}

// §III "Protection of the timing mechanism": the timer and the checkpoint calls are unreachable while the
// system is vulnerable, so no Checkpoint right of any kind in MC (§IV-C: "calls ... are disabled in MC").
void check_timer(const Context& c, Findings& out) {
  for (const Grant& g : c.policy.grants()) {
    if (c.policy.object(g.object).kind == ObjectKind::Checkpoint && g.modes.has(SrMode::MC)) {
      add(out, Invariant::Timer,
          "grant of " + describe(c.policy, g, kMcOnly) +
              ": no Checkpoint right in MC, an attacker in MC could re-arm or cancel the rejuvenation timer "
              "(§III)",
          g.where);
    }
  }
}

// §III "Secure Execution Interval": no network communication in RB, SC, UPDATE or CP.
void check_sei(const Context& c, Findings& out) {
  for (const Grant& g : c.policy.grants()) {
    const ModeSet bad = only(g.modes, kSei);
    if (c.policy.object(g.object).kind == ObjectKind::Network && !bad.empty()) {
      add(out, Invariant::Sei,
          "grant of " + describe(c.policy, g, bad) +
              ": the network must be off during the secure execution interval (RB, SC, UPDATE, CP; §III, "
              "§IV-D)",
          g.where);
    }
  }
}

// §III "Limits on Control Uncertainty" and §IV-C: the limits are set outside MC by the rejuvenation module
// and applied at the driver level, where no application can read (or be steered by) them.
void check_limits(const Context& c, Findings& out) {
  for (const Grant& g : c.policy.grants()) {
    if (c.policy.object(g.object).kind != ObjectKind::Limits) {
      continue;
    }
    const Service& s = c.policy.service(g.service);
    if (g.rights.has(Right::Write) && g.modes.has(SrMode::MC)) {
      add(out, Invariant::Limits,
          "grant of " + describe(c.policy, g, kMcOnly) +
              ": Limits Write in MC would let an attacker lift the restricted limits (§III, §IV-C)",
          g.where);
    }
    if (g.rights.has(Right::Write) && !s.rejuvenation) {
      add(out, Invariant::Limits,
          "grant of " + describe(c.policy, g, g.modes) +
              ": only the rejuvenation service (`rejuvenation: true`) may write Limits (§IV-C)",
          g.where);
    }
    if (g.rights.has(Right::Read) && s.level != ServiceLevel::Driver) {
      add(out, Invariant::Limits,
          "grant of " + describe(c.policy, g, g.modes) +
              ": Limits are applied at the driver level; only a `level: DRIVER` service may read them (§III)",
          g.where);
    }
  }
}

// §III "Persistent Data": data that survives rollback must not be writable from the network's reach in MC,
// or an attack would outlive the rejuvenation that is meant to erase it.
void check_persistent(const Context& c, Findings& out) {
  for (const Grant& g : c.policy.grants()) {
    if (c.policy.object(g.object).kind == ObjectKind::Persistent && g.rights.has(Right::Write) &&
        g.modes.has(SrMode::MC) && c.policy.is_network_facing(g.service)) {
      add(out, Invariant::Persistent,
          "grant of " + describe(c.policy, g, kMcOnly) + ": \"" + c.policy.service(g.service).name +
              "\" is network-facing; a Persistent Write in MC survives rollback and would carry an attack "
              "across it (§III)",
          g.where);
    }
  }
}

// docs/design.md §4 `lateral`: a compromised network-facing service must not steer or move the vehicle directly;
// commands from outside go through a validating service (mission_upload → commander → mission).
void check_lateral(const Context& c, Findings& out) {
  for (const Grant& g : c.policy.grants()) {
    const Object& o = c.policy.object(g.object);
    if (o.kind == ObjectKind::Topic && o.role != TopicRole::Data && g.rights.has(Right::Write) &&
        c.policy.is_network_facing(g.service)) {
      add(out, Invariant::Lateral,
          "grant of " + describe(c.policy, g, g.modes) + ": \"" + c.policy.service(g.service).name +
              "\" is network-facing and may not publish the " + std::string(to_string(o.role)) + " topic \"" +
              o.name + "\"; route it through a validating service",
          g.where);
    }
  }
}

// §V, Fig. 5: the rollback handler takes the checkpoints. A rejuvenation service without Checkpoint Write in
// the secure interval can never take one, and an SR graph without such a service never has an image: its
// first rollback has nothing to restore.
bool can_checkpoint(const Policy& p, ServiceId service) {
  return std::any_of(p.grants().begin(), p.grants().end(), [&](const Grant& g) {
    return g.service == service && p.object(g.object).kind == ObjectKind::Checkpoint && g.rights.has(Right::Write) &&
           !only(g.modes, kSei).empty();
  });
}

void check_checkpoint(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  bool any = false;
  for (const Service& s : p.services()) {
    if (!s.rejuvenation) {
      continue;
    }
    if (can_checkpoint(p, s.id)) {
      any = true;
      continue;
    }
    add(out, Invariant::Checkpoint,
        "rejuvenation service \"" + s.name +
            "\" holds no Write on a Checkpoint object in the secure interval (RB, SC, UPDATE, CP): it could "
            "never take a checkpoint, so there would be no image to roll back to (§V)",
        s.where);
    any = true;  // reported once, at the service
  }
  if (c.graph != nullptr && c.graph->graph.sr().enabled() && !any) {
    add(out, Invariant::Checkpoint,
        "the graph runs SR (sr.enabled) but the policy " + p.file() +
            " has no rejuvenation service (`rejuvenation: true`) holding Checkpoint Write in the secure interval: "
            "no checkpoint could ever be taken (§V)",
        c.graph->locations.locate({{"sr", -1}}, "enabled"));
  }
}

// A service the network reaches: declared network-facing, or able to receive from a Network object (a
// send-only holder takes no input from outside).
bool reached_by_network(const Policy& p, ServiceId service) {
  if (p.service(service).declared_network_facing) {
    return true;
  }
  return std::any_of(p.grants().begin(), p.grants().end(), [&](const Grant& g) {
    return g.service == service && p.object(g.object).kind == ObjectKind::Network && g.rights.has(Right::Read);
  });
}

// §III, §IV-C: the mode switch is part of the SR machinery. A service the network reaches that may request
// a mode in MC could leave MC (or skip the rollback's SC) at an attacker's command.
void check_mode(const Context& c, Findings& out) {
  for (const Grant& g : c.policy.grants()) {
    if (c.policy.object(g.object).kind == ObjectKind::Mode && !g.rights.empty() && g.modes.has(SrMode::MC) &&
        reached_by_network(c.policy, g.service)) {
      add(out, Invariant::Mode,
          "grant of " + describe(c.policy, g, kMcOnly) + ": \"" + c.policy.service(g.service).name +
              "\" is reached by the network; a mode request from it in MC would put the SR cycle in an "
              "attacker's hands (§III, §IV-C)",
          g.where);
    }
  }
}

// §III "Limits on Control Uncertainty": the restricted limits Ū are what bounds an attack in MC, so the
// driver that applies them must read them in MC; without it the driver falls back to the graph's Ū and
// the rejuvenation service's limits never apply.
void check_restricted(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  for (const Grant& g : p.grants()) {
    if (p.object(g.object).kind == ObjectKind::Limits && g.rights.has(Right::Read) &&
        p.service(g.service).level == ServiceLevel::Driver && !g.modes.has(SrMode::MC)) {
      add(out, Invariant::Restricted,
          "grant of " + describe(p, g, g.modes) + ": the driver reads the limits only in the secure interval; "
              "they bind in MC (§III): add MC",
          g.where);
    }
  }
  for (const Object& o : p.objects()) {
    if (o.kind != ObjectKind::Limits) {
      continue;
    }
    const auto writer = std::find_if(p.grants().begin(), p.grants().end(), [&](const Grant& g) {
      return g.object == o.id && g.rights.has(Right::Write);
    });
    const bool read_in_mc = std::any_of(p.grants().begin(), p.grants().end(), [&](const Grant& g) {
      return g.object == o.id && g.rights.has(Right::Read) && p.service(g.service).level == ServiceLevel::Driver;
    });
    if (writer != p.grants().end() && !read_in_mc) {
      add(out, Invariant::Restricted,
          "grant of " + describe(p, *writer, writer->modes) + ": the limits \"" + o.name +
              "\" are written but no driver-level service reads them, so they never apply (§III)",
          writer->where);
    }
  }
}

// Fig. 1, docs/design.md §8: in the secure interval only the safety controller drives. The mission controller (a
// rolled-back service that publishes an ACTUATOR topic in MC, where it may be compromised) publishes none
// there. Driver-level services are trusted and never rolled back.
void check_controls(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  for (const Grant& g : p.grants()) {
    const Object& o = p.object(g.object);
    if (o.kind != ObjectKind::Topic || o.role != TopicRole::Actuator || !g.rights.has(Right::Write) ||
        p.service(g.service).level == ServiceLevel::Driver) {
      continue;
    }
    const bool drives_in_mc = std::any_of(p.grants().begin(), p.grants().end(), [&](const Grant& h) {
      const Object& ho = p.object(h.object);
      return h.service == g.service && ho.kind == ObjectKind::Topic && ho.role == TopicRole::Actuator &&
             h.rights.has(Right::Write) && h.modes.has(SrMode::MC);
    });
    const ModeSet bad = only(g.modes, kSei);
    if (drives_in_mc && !bad.empty()) {
      add(out, Invariant::Controls,
          "grant of " + describe(p, g, bad) + ": \"" + p.service(g.service).name +
              "\" drives in MC (the mission controller); in the secure interval only the safety controller "
              "publishes actuator topics (Fig. 1)",
          g.where);
    }
  }
}

// ---- coverage: every name resolves, uses and grants agree, topics have both ends (docs/design.md §4) ----

void coverage_policy_only(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  for (const Service& s : p.services()) {
    const bool granted =
        std::any_of(p.grants().begin(), p.grants().end(), [&](const Grant& g) { return g.service == s.id; });
    if (!granted) {
      add(out, Invariant::Coverage, "service \"" + s.name + "\" appears in no grant: it could do nothing",
          s.where);
    }
  }
  for (const Object& o : p.objects()) {
    const bool granted =
        std::any_of(p.grants().begin(), p.grants().end(), [&](const Grant& g) { return g.object == o.id; });
    if (!granted && o.kernel == KernelEndpoint::None) {
      add(out, Invariant::Coverage, "object \"" + o.name + "\" appears in no grant: remove it or grant it",
          o.where);
    }
  }
  for (const Grant& g : p.grants()) {
    const Object& o = p.object(g.object);
    if (o.kernel == KernelEndpoint::Publishes && g.rights.has(Right::Write)) {
      add(out, Invariant::Coverage,
          "grant of " + describe(p, g, g.modes) + ": \"" + o.name +
              "\" is published by the kernel (kernel: KERNEL_PUBLISHES); a service writer could forge it",
          g.where);
    }
  }
}

const proto::Use* find_use(const proto::ServiceSpec& s, std::string_view object) {
  for (const proto::Use& u : s.uses()) {
    if (u.object() == object) {
      return &u;
    }
  }
  return nullptr;
}

void coverage_names(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  const proto::Launch& g = c.graph->graph;
  const TextLocations& at = c.graph->locations;
  std::vector<std::string> declared;
  for (const Service& s : p.services()) declared.push_back(s.name);
  for (int i = 0; i < g.services_size(); ++i) {
    const proto::ServiceSpec& ls = g.services(i);
    const auto id = p.find_service(ls.name());
    if (!id) {
      add(out, Invariant::Coverage,
          "launch service \"" + ls.name() + "\" is not declared in the policy " + p.file() +
              did_you_mean(ls.name(), declared),
          at.locate({{"services", i}}, "name"));
      continue;
    }
    // The driver level of §IV-C is one fact stated twice: never rolled back (launch) and trusted (policy).
    const bool driver = p.service(*id).level == ServiceLevel::Driver;
    if (driver == launch::rejuvenate(ls)) {
      add(out, Invariant::Coverage,
          "service \"" + ls.name() + "\" is " +
              (driver ? "level: DRIVER in the policy but rejuvenated"
                      : "rolled back in the policy (APPLICATION) but has rejuvenate: false") +
              " in the graph; driver level means `rejuvenate: false` and `level: DRIVER`",
          at.locate({{"services", i}}, driver ? "name" : "rejuvenate"));
    }
  }
  for (const Service& s : p.services()) {
    if (launch::find_service(g, s.name) == nullptr) {
      add(out, Invariant::Coverage,
          "policy service \"" + s.name + "\" is not in the launch graph " + c.graph->path.string(), s.where);
    }
  }
}

void coverage_uses(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  const proto::Launch& g = c.graph->graph;
  const TextLocations& at = c.graph->locations;
  for (int i = 0; i < g.services_size(); ++i) {
    const proto::ServiceSpec& ls = g.services(i);
    const auto sid = p.find_service(ls.name());
    if (!sid) {
      continue;  // reported by coverage_names
    }
    for (int u = 0; u < ls.uses_size(); ++u) {
      const proto::Use& use = ls.uses(u);
      const auto oid = p.find_object(use.object());
      if (!oid) {
        add(out, Invariant::Coverage,
            "\"" + ls.name() + "\" uses \"" + use.object() + "\", which is not an object of the policy",
            at.locate({{"services", i}, {"uses", u}}, "object"));
        continue;
      }
      const Rights wanted = Rights::parse(use.rights()).value_or(Rights::none());  // validated by the loader
      const Rights granted = p.rights_any_mode(*sid, *oid);
      if (!granted.contains(wanted)) {
        add(out, Invariant::Coverage,
            "\"" + ls.name() + "\" uses \"" + use.rights() + "\" on \"" + use.object() +
                "\" but the policy grants " +
                (granted.empty() ? "nothing" : "only \"" + granted.letters() + "\"") + " in any mode",
            at.locate({{"services", i}, {"uses", u}}, "rights"));
      }
    }
  }
  // A dead grant is a right nobody asked for: least privilege says remove it.
  for (const Grant& gr : p.grants()) {
    const proto::ServiceSpec* ls = launch::find_service(g, p.service(gr.service).name);
    if (ls == nullptr) {
      continue;  // reported by coverage_names
    }
    const proto::Use* use = find_use(*ls, p.object(gr.object).name);
    const Rights used =
        use == nullptr ? Rights::none() : Rights::parse(use->rights()).value_or(Rights::none());
    if (!used.contains(gr.rights)) {
      Rights unused;
      for (const Right r : {Right::Read, Right::Write, Right::Grant}) {
        if (gr.rights.has(r) && !used.has(r)) {
          unused = unused | r;
        }
      }
      add(out, Invariant::Coverage,
          "dead grant " + describe(p, gr, gr.modes) + ": the graph's \"" + ls->name() + "\" " +
              (use == nullptr ? "does not use \"" + p.object(gr.object).name + "\""
                              : "uses only \"" + use->rights() + "\", not \"" + unused.letters() + "\""),
          gr.where);
    }
  }
}

// Every topic read has a writer and every topic written has a reader (docs/design.md §4, §5): a service with the
// right in some mode, a DDS bridge (IN writes into the kernel, OUT reads out of it) or the kernel itself.
void coverage_topics(const Context& c, Findings& out) {
  const Policy& p = c.policy;
  const proto::DdsSpec& dds = c.graph->graph.dds();
  const TextLocations& at = c.graph->locations;
  struct Ends {
    std::optional<SourceLocation> first_writer, first_reader;
    bool written = false, read = false;
  };
  std::vector<Ends> ends(p.objects().size());
  for (const Grant& g : p.grants()) {
    Ends& e = ends[g.object.value()];
    if (g.rights.has(Right::Write)) {
      e.written = true;
      e.first_writer = e.first_writer.value_or(g.where);
    }
    if (g.rights.has(Right::Read)) {
      e.read = true;
      e.first_reader = e.first_reader.value_or(g.where);
    }
  }
  for (int b = 0; b < dds.bridges_size(); ++b) {
    const proto::Bridge& br = dds.bridges(b);
    const SourceLocation where = at.locate({{"dds", -1}, {"bridges", b}}, "topic");
    const auto oid = p.find_object(br.topic());
    if (!oid || p.object(*oid).kind != ObjectKind::Topic) {
      add(out, Invariant::Coverage, "bridge names \"" + br.topic() + "\", which is not a topic of the policy",
          where);
      continue;
    }
    Ends& e = ends[oid->value()];
    if (br.direction() == proto::BRIDGE_IN) {
      e.written = true;
      e.first_writer = e.first_writer.value_or(where);
    } else {
      e.read = true;
      e.first_reader = e.first_reader.value_or(where);
    }
  }
  for (const Object& o : p.objects()) {
    if (o.kind != ObjectKind::Topic) {
      continue;
    }
    const Ends& e = ends[o.id.value()];
    const bool written = e.written || o.kernel == KernelEndpoint::Publishes;
    const bool read = e.read || o.kernel == KernelEndpoint::Subscribes;
    if (read && !written && e.first_reader) {
      add(out, Invariant::Coverage,
          "topic \"" + o.name +
              "\" is read but nobody writes it: grant W to a service, bridge it IN, or mark "
              "it kernel: KERNEL_PUBLISHES",
          *e.first_reader);
    }
    if (written && !read && e.first_writer) {
      add(out, Invariant::Coverage,
          "topic \"" + o.name + "\" is written but nobody reads it: grant R to a service or bridge it OUT",
          *e.first_writer);
    }
  }
}

void check_coverage(const Context& c, Findings& out) {
  coverage_policy_only(c, out);
  if (c.graph != nullptr) {
    coverage_names(c, out);
    coverage_uses(c, out);
    coverage_topics(c, out);
  }
}

bool matches(const Policy& p, const DenyRule& r, const Grant& g) {
  if (std::find(r.except_services.begin(), r.except_services.end(), g.service) != r.except_services.end()) {
    return false;
  }
  return (!r.service || *r.service == g.service) && (!r.object || *r.object == g.object) &&
         (!r.kind || *r.kind == p.object(g.object).kind) &&
         (r.rights.empty() || r.rights.intersects(g.rights)) && r.modes.intersects(g.modes);
}

// The policy's own rules (docs/design.md §4): intent that must keep holding as grants are edited.
void check_deny(const Context& c, Findings& out) {
  for (const DenyRule& r : c.policy.deny_rules()) {
    for (const Grant& g : c.policy.grants()) {
      if (matches(c.policy, r, g)) {
        const Rights hit = r.rights.empty() ? g.rights : (r.rights & g.rights);
        const Grant shown{g.service, g.object, hit, g.modes, g.where};
        out.push_back(Finding{Invariant::Deny, r.id,
                              "grant of " + describe(c.policy, shown, only(g.modes, r.modes)) +
                                  " matches deny rule \"" + r.id + "\"" +
                                  (r.reason.empty() ? "" : ": " + r.reason),
                              g.where});
      }
    }
  }
}

// The graph across hosts (docs/across_hosts.md, hosts.hpp); graph-side only. Three rules, each its own id:
//   hosts:mc-only        a topic crosses between hosts only in MC: the secure interval closes every link (§III)
//   hosts:vehicle        a service that acts in the secure interval runs on the vehicle's host
//   hosts:remote-writer  an ACTUATOR or SETPOINT topic is written from another host only by a service the
//                        topic's `remote_writers` names
void add_hosts(Findings& out, std::string rule, std::string message, SourceLocation where) {
  out.push_back(Finding{Invariant::Hosts, std::move(rule), std::move(message), std::move(where)});
}

void check_hosts(const Context& c, Findings& out) {
  if (c.graph == nullptr) return;
  const Policy& p = c.policy;
  const Placement place = placement(p, *c.graph);
  if (place.hosts.size() < 2) return;
  const auto host = [&](std::size_t h) { return "host \"" + place.hosts[h] + "\""; };
  for (const Crossing& x : crossings(p, place)) {
    const ModeSet outside = only(x.modes, kSei);
    if (outside.empty()) continue;
    const Grant& w = p.grants()[x.grant_writer];
    const Grant& r = p.grants()[x.grant_reader];
    // The grant to change is the one off the vehicle (the reader's when both are).
    const Grant& at = x.reader_host != 0 ? r : w;
    add_hosts(out, "mc-only",
              "topic \"" + p.object(x.topic).name + "\" crosses from " + host(x.writer_host) + " (\"" +
                  p.service(w.service).name + "\" writes it) to " + host(x.reader_host) + " (\"" +
                  p.service(r.service).name + "\" reads it) in " + outside.to_string() +
                  ": a cross-host topic may be granted only in MC (every link is closed in the secure interval); "
                  "grant \"" + p.service(at.service).name + "\" this topic in MC only",
              at.where);
  }
  const proto::Launch& g = c.graph->graph;
  for (int i = 0; i < g.services_size(); ++i) {
    const auto id = p.find_service(g.services(i).name());
    if (!id) continue;
    const auto h = place.of(*id);
    if (!h || *h == 0) continue;
    const Service& s = p.service(*id);
    const SourceLocation where = c.graph->locations.locate({{"services", i}}, "host");
    // A link (hosts.hpp) is a driver on every host by construction: its rights are MC-only, which the
    // `mc-only` rule checks for every crossing it makes.
    if (acts_in_secure_interval(p, *id) && !is_host_link(g, g.services(i))) {
      const std::string why = s.rejuvenation                     ? "it is the rejuvenation service"
                              : s.level == ServiceLevel::Driver ? "it is a driver"
                                                                 : "it writes in the secure interval";
      add_hosts(out, "vehicle",
                "service \"" + s.name + "\" acts in the secure interval (" + why + ") but runs on " + host(*h) +
                    ": it must run on the vehicle's " + host(0) + ", where the secure interval closes no link it needs",
                where);
    }
    for (const Grant& gr : p.grants()) {
      const Object& o = p.object(gr.object);
      if (gr.service != *id || !gr.rights.has(Right::Write) || o.kind != ObjectKind::Topic ||
          o.role == TopicRole::Data) {
        continue;
      }
      if (std::find(o.remote_writers.begin(), o.remote_writers.end(), *id) != o.remote_writers.end()) continue;
      add_hosts(out, "remote-writer",
                "service \"" + s.name + "\" on " + host(*h) + " writes the " + std::string(to_string(o.role)) +
                    " topic \"" + o.name + "\": it steers the vehicle from another host than the vehicle's " +
                    host(0) + "; run it there, or name it in the topic's `remote_writers`",
                where);
    }
  }
}

// One small function per invariant, in the order of docs/design.md §4.
struct InvariantCheck {
  Invariant invariant;
  void (*run)(const Context&, Findings&);
};
constexpr std::array kChecks{
    InvariantCheck{Invariant::Timer, check_timer},
    InvariantCheck{Invariant::Sei, check_sei},
    InvariantCheck{Invariant::Limits, check_limits},
    InvariantCheck{Invariant::Persistent, check_persistent},
    InvariantCheck{Invariant::Lateral, check_lateral},
    InvariantCheck{Invariant::Checkpoint, check_checkpoint},
    InvariantCheck{Invariant::Mode, check_mode},
    InvariantCheck{Invariant::Restricted, check_restricted},
    InvariantCheck{Invariant::Controls, check_controls},
    InvariantCheck{Invariant::Coverage, check_coverage},
    InvariantCheck{Invariant::Deny, check_deny},
    InvariantCheck{Invariant::Hosts, check_hosts},
};
static_assert(kChecks.size() == kAllInvariants.size(), "every invariant has its check");

Findings run(const Context& c) {
  Findings out;
  for (const InvariantCheck& check : kChecks) {
    check.run(c, out);
  }
  // Compiler order: by file, then position; stable so one grant's findings keep the table order.
  std::stable_sort(out.begin(), out.end(), [](const Finding& a, const Finding& b) {
    return std::tie(a.where.file, a.where.line, a.where.column) <
           std::tie(b.where.file, b.where.line, b.where.column);
  });
  return out;
}

}  // namespace

std::vector<Finding> audit(const Policy& policy) {
  return run(Context{policy, nullptr});
}

std::vector<Finding> audit(const Policy& policy, const launch::LoadedLaunch& graph) {
  return run(Context{policy, &graph});
}

std::vector<MatrixRow> matrix(const Policy& policy) {
  std::vector<MatrixRow> rows;
  for (const Service& s : policy.services()) {
    for (const Object& o : policy.objects()) {
      if (policy.rights_any_mode(s.id, o.id).empty()) {
        continue;
      }
      MatrixRow row{s.id, o.id, {}};
      for (const SrMode m : kAllModes) {
        row.rights[index_of(m)] = policy.rights(s.id, o.id, m);
      }
      rows.push_back(row);
    }
  }
  return rows;
}

Result<void, LoadError> check_used_objects(const Policy& policy, const launch::LoadedLaunch& graph) {
  std::vector<std::string> names;
  for (const Object& o : policy.objects()) names.push_back(o.name);
  const proto::Launch& g = graph.graph;
  for (int i = 0; i < g.services_size(); ++i) {
    const proto::ServiceSpec& s = g.services(i);
    for (int u = 0; u < s.uses_size(); ++u) {
      const std::string& object = s.uses(u).object();
      if (policy.find_object(object)) continue;
      return fail(semantic_error(graph.locations.locate({{"services", i}, {"uses", u}}, "object"),
                                 "service \"" + s.name() + "\" uses \"" + object + "\", which is no object of the policy " +
                                     policy.file() + did_you_mean(object, names)));
    }
  }
  return {};
}

}  // namespace rejuv::policy
