// The policy loader (docs/design.md §3–§4): text → proto::Policy → a validated Policy, and its compilation to the
// kernel's per-mode table. Above 600 lines on purpose: the checks are one builder (PolicyBuilder) whose
// order is part of the contract (the first problem in file order is the one reported, with its location);
// the audit (audit.cpp) is the other half of the policy's verdicts.
#include "rejuv/policy/policy.hpp"

#include <algorithm>
#include <bit>

#include "policy.pb.h"

namespace rejuv::policy {

std::string_view to_string(TopicRole role) {
  switch (role) {
    case TopicRole::Data: return "DATA";
    case TopicRole::Actuator: return "ACTUATOR";
    case TopicRole::Setpoint: return "SETPOINT";
  }
  return "?";
}

std::string_view to_string(ServiceLevel level) {
  switch (level) {
    case ServiceLevel::Application: return "APPLICATION";
    case ServiceLevel::Driver: return "DRIVER";
  }
  return "?";
}

namespace {

using Step = TextLocations::Step;
using Check = Result<void, LoadError>;

// Protobuf enums are open (proto3 accepts `kind: 42`), so each is converted to the project's enum class
// with an explicit "not one of ours" outcome. Switching on the integer keeps -Wswitch-enum meaningful for
// our own enums without listing protobuf's sentinels.
std::optional<SrMode> to_mode(int m) {
  switch (m) {
    case proto::MC: return SrMode::MC;
    case proto::RB: return SrMode::RB;
    case proto::SC: return SrMode::SC;
    case proto::UPDATE: return SrMode::Update;
    case proto::CP: return SrMode::CP;
    default: return std::nullopt;  // MODE_UNSPECIFIED or a number the schema does not define
  }
}

std::optional<ObjectKind> to_kind(int k) {
  switch (k) {
    case proto::TOPIC: return ObjectKind::Topic;
    case proto::CHECKPOINT: return ObjectKind::Checkpoint;
    case proto::NETWORK: return ObjectKind::Network;
    case proto::LIMITS: return ObjectKind::Limits;
    case proto::PERSISTENT: return ObjectKind::Persistent;
    case proto::MODE: return ObjectKind::Mode;
    default: return std::nullopt;
  }
}

std::optional<TopicRole> to_role(int r) {
  switch (r) {
    case proto::DATA: return TopicRole::Data;
    case proto::ACTUATOR: return TopicRole::Actuator;
    case proto::SETPOINT: return TopicRole::Setpoint;
    default: return std::nullopt;
  }
}

std::optional<ServiceLevel> to_level(int l) {
  switch (l) {
    case proto::APPLICATION: return ServiceLevel::Application;
    case proto::DRIVER: return ServiceLevel::Driver;
    default: return std::nullopt;
  }
}

std::optional<KernelEndpoint> to_endpoint(int e) {
  switch (e) {
    case proto::KERNEL_NONE: return KernelEndpoint::None;
    case proto::KERNEL_PUBLISHES: return KernelEndpoint::Publishes;
    case proto::KERNEL_SUBSCRIBES: return KernelEndpoint::Subscribes;
    default: return std::nullopt;
  }
}

// Names appear in boot info, audit output and deny rules ("*" is the wildcard): keep them plain.
// An IDL scoped name: identifiers (a letter or '_', then letters, digits, '_') joined by "::".
bool is_scoped_name(std::string_view s) {
  if (s.empty() || s.size() > 63) return false;  // wire::BootCap::type holds 63 characters
  bool start = true;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    const bool letter = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
    if (start) {
      if (!letter) return false;
      start = false;
    } else if (c == ':') {
      if (i + 2 >= s.size() || s[i + 1] != ':') return false;
      ++i;
      start = true;
    } else if (!letter && !(c >= '0' && c <= '9')) {
      return false;
    }
  }
  return !start;
}

bool is_plain_name(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

// " (did you mean \"x\"?)" for a typo of a declared name (did_you_mean over their names).
template <class Named>
std::string suggestion(std::string_view name, const std::vector<Named>& known) {
  std::vector<std::string> names;
  names.reserve(known.size());
  for (const Named& k : known) names.push_back(k.name);
  return did_you_mean(name, names);
}

// Why a rights string is refused, in the user's terms.
std::string explain_rights(std::string_view letters) {
  if (letters.empty()) {
    return "rights are empty: expected one or more of R (read), W (write), G (grant), e.g. \"RW\"";
  }
  for (std::size_t i = 0; i < letters.size(); ++i) {
    const char c = letters[i];
    if (c != 'R' && c != 'W' && c != 'G') {
      return "bad rights \"" + std::string(letters) + "\": unknown letter '" + std::string(1, c) +
             "', expected letters from R (read), W (write), G (grant)";
    }
    if (letters.find(c) != i) {
      return "bad rights \"" + std::string(letters) + "\": letter '" + std::string(1, c) +
             "' is repeated; each right is written once";
    }
  }
  return "bad rights \"" + std::string(letters) + "\"";
}

}  // namespace

// Turns a parsed proto::Policy into a Policy, refusing the first semantic problem (decode, then build:
// nothing is returned unless every check passed).
class PolicyBuilder {
 public:
  PolicyBuilder(const proto::Policy& pb, const TextLocations& locs) : pb_(pb), locs_(locs) {}

  Result<Policy, LoadError> build() {
    p_.name_ = pb_.name();
    p_.file_ = locs_.file();
    for (Check c : {types(), services(), objects(), grants(), deny()}) {
      if (!c) {
        return fail(std::move(c.error()));
      }
    }
    // An empty policy would audit clean and grant nothing: almost certainly the wrong file.
    if (p_.services_.empty()) {
      return fail(
          error(at({}, "name"), "the policy declares no `services`: expected services { name: \"...\" }"));
    }
    return std::move(p_);
  }

 private:
  [[nodiscard]] static LoadError error(SourceLocation where, std::string message) {
    return semantic_error(std::move(where), std::move(message));
  }
  [[nodiscard]] SourceLocation at(std::initializer_list<Step> path, std::string_view field,
                                  int index = -1) const {
    return locs_.locate(path, field, index);
  }
  [[nodiscard]] static std::string line_of(const SourceLocation& w) {
    return "line " + std::to_string(w.line);
  }

  // The graph's own topic types (proto TopicType). What they are is checked here; whether the structs a
  // service was built with have these sizes, by the SDK at advertise/subscribe (SdkError::TypeMismatch).
  Check types() {
    for (int i = 0; i < pb_.types_size(); ++i) {
      const proto::TopicType& t = pb_.types(i);
      const auto field = [&](std::string_view f) { return at({{"types", i}}, f); };
      if (!is_scoped_name(t.name())) {
        return fail(error(field("name"), t.name().empty()
                                             ? std::string("type without a `name`")
                                             : "type name \"" + t.name() +
                                                   "\" must be an IDL scoped name such as \"hello::Greeting\""));
      }
      if (t.name().starts_with("rejuv::")) {
        return fail(error(field("name"), "type \"" + t.name() +
                                             "\": names under rejuv:: are the project's own (idl/*.idl); use "
                                             "your IDL module's name"));
      }
      if (const DeclaredType* dup = p_.find_type(t.name())) {
        return fail(error(field("name"), "duplicate type \"" + t.name() + "\": already declared at " +
                                             line_of(dup->where)));
      }
      if (t.size_bytes() < 1 || t.size_bytes() > kMaxTopicBytes) {
        return fail(error(field(t.size_bytes() == 0 ? "name" : "size_bytes"),
                          "type \"" + t.name() + "\" needs size_bytes in 1.." + std::to_string(kMaxTopicBytes) +
                              " (a message travels in one channel frame), got " + std::to_string(t.size_bytes())));
      }
      if (!std::has_single_bit(t.align_bytes()) || t.align_bytes() > 16 || t.size_bytes() % t.align_bytes() != 0) {
        return fail(error(field(t.align_bytes() == 0 ? "name" : "align_bytes"),
                          "type \"" + t.name() + "\" needs align_bytes a power of two up to 16 that divides its size " +
                              std::to_string(t.size_bytes()) + ", got " + std::to_string(t.align_bytes())));
      }
      p_.types_.push_back(DeclaredType{t.name(), t.size_bytes(), t.align_bytes(), at({}, "types", i)});
    }
    return {};
  }

  Check services() {
    std::size_t rejuvenation_at = 0;
    for (int i = 0; i < pb_.services_size(); ++i) {
      const proto::Service& s = pb_.services(i);
      const SourceLocation name_at = at({{"services", i}}, "name");
      if (!is_plain_name(s.name()) || s.name() == "*") {
        return fail(error(name_at, s.name().empty() ? std::string("service without a `name`")
                                                    : "service name \"" + s.name() +
                                                          "\" must use only letters, digits, '_', '-', '.'"));
      }
      if (const auto dup = p_.find_service(s.name())) {
        return fail(error(name_at, "duplicate service \"" + s.name() + "\": already declared at " +
                                       line_of(p_.service(*dup).where)));
      }
      const auto level = to_level(s.level());
      if (!level) {
        return fail(
            error(at({{"services", i}}, "level"),
                  "unknown service level " + std::to_string(s.level()) + ": expected APPLICATION or DRIVER"));
      }
      Service svc{ServiceId(static_cast<std::uint32_t>(i)),
                  s.name(),
                  *level,
                  s.rejuvenation(),
                  s.network_facing(),
                  at({}, "services", i)};
      // §V: one Checkpoint/Rollback module; two would each believe they own the timer.
      if (s.rejuvenation()) {
        if (rejuvenation_at != 0) {
          return fail(error(at({{"services", i}}, "rejuvenation"),
                            "second `rejuvenation: true` service \"" + s.name() +
                                "\": only one service (line " + std::to_string(rejuvenation_at) +
                                ") may be the rejuvenation service"));
        }
        rejuvenation_at = static_cast<std::size_t>(std::max(svc.where.line, 1));
      }
      p_.services_.push_back(std::move(svc));
    }
    return {};
  }

  Check objects() {
    for (int i = 0; i < pb_.objects_size(); ++i) {
      auto obj = declared_object(i);
      if (!obj) {
        return fail(std::move(obj.error()));
      }
      p_.objects_.push_back(std::move(*obj));
    }
    return {};
  }

  [[nodiscard]] SourceLocation object_at(int i, std::string_view field) const { return at({{"objects", i}}, field); }

  // Object i of the file: its name, kind, role and kernel endpoint, then the fields its kind takes.
  Result<Object, LoadError> declared_object(int i) const {
    const proto::Object& o = pb_.objects(i);
    if (!is_plain_name(o.name()) || o.name() == "*") {
      return fail(error(object_at(i, "name"), o.name().empty()
                                                  ? std::string("object without a `name`")
                                                  : "object name \"" + o.name() +
                                                        "\" must use only letters, digits, '_', '-', '.'"));
    }
    if (const auto dup = p_.find_object(o.name())) {
      return fail(error(object_at(i, "name"), "duplicate object \"" + o.name() + "\": already declared at " +
                                                  line_of(p_.object(*dup).where)));
    }
    const auto kind = to_kind(o.kind());
    if (!kind) {
      return fail(
          error(object_at(i, o.kind() == proto::OBJECT_KIND_UNSPECIFIED ? "name" : "kind"),
                "object \"" + o.name() +
                    "\" needs a `kind`: expected TOPIC, CHECKPOINT, NETWORK, LIMITS, PERSISTENT or MODE"));
    }
    const auto role = to_role(o.role());
    const auto endpoint = to_endpoint(o.kernel());
    if (!role || !endpoint) {
      return fail(
          error(object_at(i, !role ? "role" : "kernel"), "object \"" + o.name() + "\": unknown enum value"));
    }
    Object obj{ObjectId(static_cast<std::uint32_t>(i)),
               o.name(),
               *kind,
               o.type(),
               *role,
               *endpoint,
               0,
               0,
               at({}, "objects", i),
               {}};
    const std::string kind_name(to_string(*kind));
    if (Check c = *kind == ObjectKind::Topic ? topic_fields(i, obj) : no_topic_fields(i, kind_name); !c) {
      return fail(std::move(c.error()));
    }
    if (Check c = size_field(i, obj, kind_name); !c) {
      return fail(std::move(c.error()));
    }
    return obj;
  }

  // A topic's type and its ring's depth.
  Check topic_fields(int i, Object& obj) const {
    const proto::Object& o = pb_.objects(i);
    if (o.type().empty()) {
      return fail(error(object_at(i, "name"),
                        "topic \"" + o.name() +
                            "\" needs a `type`: the IDL type name, e.g. type: \"rejuv::msg::Setpoint\""));
    }
    // docs/design.md §5: uORB ring of depth Q, a power of two (cursor arithmetic by masking).
    obj.queue_depth = o.queue_depth() == 0 ? kDefaultQueueDepth : o.queue_depth();
    if (!std::has_single_bit(obj.queue_depth) || obj.queue_depth > kMaxQueueDepth) {
      return fail(error(object_at(i, "queue_depth"),
                        "queue_depth " + std::to_string(o.queue_depth()) + " of topic \"" + o.name() +
                            "\" must be a power of two in 1.." + std::to_string(kMaxQueueDepth)));
    }
    // Remote writers name services allowed to steer the vehicle from another host: only a topic that
    // steers (ACTUATOR, SETPOINT) has any use for them (the `hosts` audit, docs/across_hosts.md).
    for (int j = 0; j < o.remote_writers_size(); ++j) {
      const SourceLocation where = at({{"objects", i}}, "remote_writers", j);
      if (obj.role == TopicRole::Data) {
        return fail(error(where, "`remote_writers` applies to ACTUATOR or SETPOINT topics; \"" + o.name() +
                                     "\" is DATA (any service may write it from another host)"));
      }
      auto s = known_service(o.remote_writers(j), where, "remote_writers");
      if (!s) {
        return fail(s.error());
      }
      obj.remote_writers.push_back(*s);
    }
    return {};
  }

  // Fields of a topic on an object of another kind are a sign the user meant something else: say so rather
  // than ignore them.
  Check no_topic_fields(int i, std::string_view kind_name) const {
    const proto::Object& o = pb_.objects(i);
    const auto misplaced = [&](std::string_view field) {
      return fail(error(object_at(i, field), "`" + std::string(field) + "` applies to topics only; \"" + o.name() +
                                                 "\" is a " + std::string(kind_name)));
    };
    if (o.role() != proto::DATA) return misplaced("role");
    if (!o.type().empty()) return misplaced("type");
    if (o.queue_depth() != 0) return misplaced("queue_depth");
    if (o.kernel() != proto::KERNEL_NONE) return misplaced("kernel");
    if (o.remote_writers_size() != 0) return misplaced("remote_writers");
    return {};
  }

  // A persistent cell's size; no other kind takes one.
  Check size_field(int i, Object& obj, std::string_view kind_name) const {
    const proto::Object& o = pb_.objects(i);
    if (obj.kind == ObjectKind::Persistent) {
      if (o.size_bytes() < 1 || o.size_bytes() > kMaxPersistentBytes) {
        return fail(error(object_at(i, o.size_bytes() == 0 ? "name" : "size_bytes"),
                          "persistent cell \"" + o.name() + "\" needs size_bytes in 1.." +
                              std::to_string(kMaxPersistentBytes) + ", got " + std::to_string(o.size_bytes())));
      }
      obj.size_bytes = o.size_bytes();
    } else if (o.size_bytes() != 0) {
      return fail(error(object_at(i, "size_bytes"), "`size_bytes` applies to PERSISTENT objects only; \"" +
                                                        o.name() + "\" is a " + std::string(kind_name)));
    }
    return {};
  }

  // Modes of a grant or deny rule: no MODE_UNSPECIFIED, no repeats.
  Result<ModeSet, LoadError> modes(std::string_view list, int i,
                                   const google::protobuf::RepeatedField<int>& ms) const {
    ModeSet set;
    for (int j = 0; j < ms.size(); ++j) {
      const auto m = to_mode(ms.Get(j));
      const SourceLocation where = at({{list, i}}, "modes", j);
      if (!m) {
        return fail(
            error(where, "mode " +
                             std::string(ms.Get(j) == proto::MODE_UNSPECIFIED ? "MODE_UNSPECIFIED"
                                                                              : std::to_string(ms.Get(j))) +
                             " is not a mode: expected MC, RB, SC, UPDATE or CP"));
      }
      if (set.has(*m)) {
        return fail(error(where, "mode " + std::string(to_string(*m)) + " is listed twice"));
      }
      set.add(*m);
    }
    return set;
  }

  Result<ServiceId, LoadError> known_service(const std::string& name, SourceLocation where,
                                             std::string_view what) const {
    if (name.empty()) {
      return fail(error(std::move(where), std::string(what) + " without a `service`"));
    }
    const auto id = p_.find_service(name);
    if (!id) {
      return fail(error(std::move(where), "unknown service \"" + name + "\" in " + std::string(what) +
                                              ": expected a name declared in `services`" +
                                              suggestion(name, p_.services_)));
    }
    return *id;
  }

  Result<ObjectId, LoadError> known_object(const std::string& name, SourceLocation where,
                                           std::string_view what) const {
    if (name.empty()) {
      return fail(error(std::move(where), std::string(what) + " without an `object`"));
    }
    const auto id = p_.find_object(name);
    if (!id) {
      return fail(error(std::move(where), "unknown object \"" + name + "\" in " + std::string(what) +
                                              ": expected a name declared in `objects`" +
                                              suggestion(name, p_.objects_)));
    }
    return *id;
  }

  Check grants() {
    const std::size_t n_obj = p_.objects_.size();
    p_.cells_.assign(p_.services_.size() * n_obj * kModeCount, Cell{});
    for (int i = 0; i < pb_.grants_size(); ++i) {
      const proto::Grant& g = pb_.grants(i);
      const SourceLocation grant_at = at({}, "grants", i);
      const auto service = known_service(g.service(), at({{"grants", i}}, "service"), "grant");
      if (!service) {
        return fail(service.error());
      }
      const auto object = known_object(g.object(), at({{"grants", i}}, "object"), "grant");
      if (!object) {
        return fail(object.error());
      }
      const auto rights = Rights::parse(g.rights());
      if (!rights) {
        return fail(error(at({{"grants", i}}, "rights"), explain_rights(g.rights())));
      }
      auto ms = modes("grants", i, g.modes());
      if (!ms) {
        return fail(ms.error());
      }
      if (ms->empty()) {
        return fail(error(grant_at, "grant of \"" + g.rights() + "\" on \"" + g.object() + "\" to \"" +
                                        g.service() +
                                        "\" has no `modes`: expected e.g. modes: [MC, RB, SC, UPDATE, CP]"));
      }
      // One grant per (service, object, mode): two would make the cell's origin ambiguous and usually
      // mean a copy-paste that widened rights by accident.
      const std::size_t index = p_.grants_.size();
      for (const SrMode m : kAllModes) {
        if (!ms->has(m)) {
          continue;
        }
        const Cell& c = p_.cell(*service, *object, m);
        if (c.grant) {
          const Grant& earlier = p_.grants_[*c.grant];
          ModeSet both;
          for (const SrMode x : kAllModes) {
            if (earlier.modes.has(x) && ms->has(x)) {
              both.add(x);
            }
          }
          return fail(error(grant_at, "duplicate grant: \"" + g.service() + "\" on \"" + g.object() +
                                          "\" is already granted in " + both.to_string() + " at " +
                                          line_of(earlier.where) + "; merge the rights or split the modes"));
        }
      }
      for (const SrMode m : kAllModes) {
        if (ms->has(m)) {
          p_.cells_[p_.cell_index(*service, *object, m)] = Cell{*rights, index};
        }
      }
      p_.grants_.push_back(Grant{*service, *object, *rights, *ms, grant_at});
    }
    return {};
  }

  Check deny() {
    for (int i = 0; i < pb_.deny_size(); ++i) {
      const proto::Deny& d = pb_.deny(i);
      const auto field = [&](std::string_view f) { return at({{"deny", i}}, f); };
      DenyRule rule;
      rule.id = d.id();
      rule.reason = d.reason();
      rule.where = at({}, "deny", i);
      if (!is_plain_name(d.id())) {
        return fail(error(d.id().empty() ? rule.where : field("id"),
                          d.id().empty()
                              ? std::string("deny rule without an `id`: findings name it")
                              : "deny id \"" + d.id() + "\" must use only letters, digits, '_', '-', '.'"));
      }
      for (const DenyRule& other : p_.deny_) {
        if (other.id == d.id()) {
          return fail(error(field("id"),
                            "duplicate deny id \"" + d.id() + "\": already used at " + line_of(other.where)));
        }
      }
      if (d.service() != "*") {
        auto s = known_service(d.service(), d.service().empty() ? rule.where : field("service"), "deny rule");
        if (!s) {
          return fail(error(s.error().where,
                            s.error().message + (d.service().empty() ? " (use \"*\" for any)" : "")));
        }
        rule.service = *s;
      }
      if (d.object() != "*") {
        auto o = known_object(d.object(), d.object().empty() ? rule.where : field("object"), "deny rule");
        if (!o) {
          return fail(
              error(o.error().where, o.error().message + (d.object().empty() ? " (use \"*\" for any)" : "")));
        }
        rule.object = *o;
      }
      if (d.kind() != proto::OBJECT_KIND_UNSPECIFIED) {
        rule.kind = to_kind(d.kind());
        if (!rule.kind) {
          return fail(error(field("kind"), "unknown object kind " + std::to_string(d.kind())));
        }
        if (rule.object && p_.object(*rule.object).kind != *rule.kind) {
          return fail(error(field("kind"), "deny rule \"" + d.id() + "\" can never match: \"" + d.object() +
                                               "\" is a " +
                                               std::string(to_string(p_.object(*rule.object).kind)) +
                                               ", not a " + std::string(to_string(*rule.kind))));
        }
      }
      if (!d.rights().empty()) {
        const auto r = Rights::parse(d.rights());
        if (!r) {
          return fail(error(field("rights"), explain_rights(d.rights())));
        }
        rule.rights = *r;
      }
      auto ms = modes("deny", i, d.modes());
      if (!ms) {
        return fail(ms.error());
      }
      rule.modes = ms->empty() ? ModeSet::all() : *ms;
      for (int j = 0; j < d.except_services_size(); ++j) {
        auto s =
            known_service(d.except_services(j), at({{"deny", i}}, "except_services", j), "except_services");
        if (!s) {
          return fail(s.error());
        }
        rule.except_services.push_back(*s);
      }
      p_.deny_.push_back(std::move(rule));
    }
    return {};
  }

  const proto::Policy& pb_;
  const TextLocations& locs_;
  Policy p_;
};

std::size_t Policy::cell_index(ServiceId s, ObjectId o, SrMode m) const {
  REJUV_ASSERT(s.value() < services_.size() && o.value() < objects_.size(), "cell of an unknown id");
  return (static_cast<std::size_t>(s.value()) * objects_.size() + o.value()) * kModeCount + index_of(m);
}

const Service& Policy::service(ServiceId id) const {
  REJUV_ASSERT(id.value() < services_.size(), "unknown ServiceId");
  return services_[id.value()];
}

const Object& Policy::object(ObjectId id) const {
  REJUV_ASSERT(id.value() < objects_.size(), "unknown ObjectId");
  return objects_[id.value()];
}

std::optional<ServiceId> Policy::find_service(std::string_view name) const {
  for (const Service& s : services_) {
    if (s.name == name) {
      return s.id;
    }
  }
  return std::nullopt;
}

const DeclaredType* Policy::find_type(std::string_view name) const {
  for (const DeclaredType& t : types_) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

std::optional<ObjectId> Policy::find_object(std::string_view name) const {
  for (const Object& o : objects_) {
    if (o.name == name) {
      return o.id;
    }
  }
  return std::nullopt;
}

const Cell& Policy::cell(ServiceId service, ObjectId object, SrMode mode) const {
  return cells_[cell_index(service, object, mode)];
}

Rights Policy::rights_any_mode(ServiceId service, ObjectId object) const {
  Rights all;
  for (const SrMode m : kAllModes) {
    all = all | rights(service, object, m);
  }
  return all;
}

bool Policy::is_network_facing(ServiceId service) const {
  if (this->service(service).declared_network_facing) {
    return true;
  }
  return std::any_of(grants_.begin(), grants_.end(), [&](const Grant& g) {
    return g.service == service && object(g.object).kind == ObjectKind::Network && !g.rights.empty();
  });
}

Result<Policy, LoadError> parse_policy(std::string_view text, std::string name) {
  proto::Policy pb;
  auto locs = parse_composed_textproto(text, std::move(name), pb);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return PolicyBuilder(pb, *locs).build();
}

Result<Policy, LoadError> load_policy(const std::filesystem::path& path, std::span<const ExtraFragment> extra) {
  proto::Policy pb;
  auto locs = load_composed_textproto(path, pb, extra);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return PolicyBuilder(pb, *locs).build();
}

cap::ModeTable compile(const Policy& policy) {
  cap::ModeTable table;
  for (const Service& s : policy.services()) {
    table.services.push_back(s.name);
  }
  for (const Object& o : policy.objects()) {
    table.objects.push_back(cap::ObjectSpec{o.id, o.kind, o.name});
  }
  for (const Service& s : policy.services()) {
    std::uint32_t next = 1;  // slot 0 is the null CPtr
    for (const Object& o : policy.objects()) {
      if (policy.rights_any_mode(s.id, o.id).empty()) {
        continue;
      }
      cap::SlotGrant slot{s.id, Slot(next++), o.id, {}};
      for (const SrMode m : kAllModes) {
        slot.rights[index_of(m)] = policy.rights(s.id, o.id, m);
      }
      table.slots.push_back(slot);
    }
  }
  return table;
}

}  // namespace rejuv::policy
