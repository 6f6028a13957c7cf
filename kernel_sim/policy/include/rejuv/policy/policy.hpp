// The capability policy (docs/design.md §3–§4): which service holds which rights on which kernel object in each
// CPS SR mode. `load_policy` parses a *.policy.pbtxt and refuses, with file:line:column and what was
// expected, anything that cannot mean what the user intended (unknown names, duplicates, bad rights,
// grants without modes). The result is an immutable in-memory model that the audit (audit.hpp) checks
// and `compile` turns into the kernel's cap::ModeTable.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/cap/mode_table.hpp"
#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/textproto/textproto.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::policy {

// " (did you mean \"x\"?)" for a likely typo (rejuv/core/did_you_mean.hpp; the launch loader uses it too).
using ::rejuv::did_you_mean;

// What a topic carries, for the `lateral` invariant (§III "Limits", §IV-C).
enum class TopicRole : std::uint8_t { Data, Actuator, Setpoint };
[[nodiscard]] std::string_view to_string(TopicRole role);

// Trust level of a service (§III, §IV-C): a driver is never rolled back and may read protected data.
enum class ServiceLevel : std::uint8_t { Application, Driver };
[[nodiscard]] std::string_view to_string(ServiceLevel level);

// Whether the kernel itself publishes or consumes a topic (then it needs no service writer / reader).
enum class KernelEndpoint : std::uint8_t { None, Publishes, Subscribes };

// Defaults that the file may leave out (idl/policy.proto).
inline constexpr std::uint32_t kDefaultQueueDepth = 4;
inline constexpr std::uint32_t kMaxQueueDepth = 1024;
inline constexpr std::uint32_t kMaxPersistentBytes = 4096;
inline constexpr std::uint32_t kMaxTopicBytes = 4096;  // a declared topic type's size (within one channel frame)

// A service of the policy. Id = declaration order.
struct Service {
  ServiceId id;
  std::string name;
  ServiceLevel level = ServiceLevel::Application;
  bool rejuvenation = false;             // the Checkpoint/Rollback service (§V): the only Limits writer
  bool declared_network_facing = false;  // as written; see Policy::is_network_facing for the full rule
  SourceLocation where;                  // its `services` entry
};

// A kernel object. Id = declaration order. Topic-only and persistent-only fields are validated.
struct Object {
  ObjectId id;
  std::string name;
  ObjectKind kind = ObjectKind::Topic;
  std::string type;                              // Topic: IDL type name
  TopicRole role = TopicRole::Data;              // Topic
  KernelEndpoint kernel = KernelEndpoint::None;  // Topic
  std::uint32_t queue_depth = 0;                 // Topic: ring depth Q (power of two); 0 for other kinds
  std::uint32_t size_bytes = 0;                  // Persistent: cell size; 0 for other kinds
  SourceLocation where;
  std::vector<ServiceId> remote_writers;         // Topic: may write it from another host than the vehicle's
};

// One `grants` entry: rights of a service on an object in a set of modes.
struct Grant {
  ServiceId service;
  ObjectId object;
  Rights rights;
  ModeSet modes;
  SourceLocation where;  // the `grants` entry (what audit findings point at)
};

// A `deny` rule: no grant may match it (docs/design.md §4). Empty optionals and sets mean "any".
struct DenyRule {
  std::string id;
  std::optional<ServiceId> service;  // nullopt = "*"
  std::optional<ObjectId> object;    // nullopt = "*"
  std::optional<ObjectKind> kind;    // nullopt = any kind
  Rights rights;                     // none = any right
  ModeSet modes;                     // every mode when the file lists none
  std::string reason;
  std::vector<ServiceId> except_services;
  SourceLocation where;
};

// A topic type the policy declares (`types`): one of the graph's own IDL, beside the project's.
struct DeclaredType {
  std::string name;         // IDL scoped name, never under rejuv::
  std::uint32_t size_bytes = 0;
  std::uint32_t align_bytes = 0;
  SourceLocation where;
};

// Rights of one (service, object, mode) and the grant that gave them.
struct Cell {
  Rights rights;
  std::optional<std::size_t> grant;  // index into Policy::grants(); nullopt = nothing granted
};

// An immutable, validated policy. Lookups by name are linear: a policy has tens of names.
class Policy {
 public:
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] const std::vector<Service>& services() const { return services_; }
  [[nodiscard]] const std::vector<Object>& objects() const { return objects_; }
  [[nodiscard]] const std::vector<Grant>& grants() const { return grants_; }
  [[nodiscard]] const std::vector<DenyRule>& deny_rules() const { return deny_; }
  [[nodiscard]] const std::vector<DeclaredType>& types() const { return types_; }
  [[nodiscard]] const DeclaredType* find_type(std::string_view name) const;

  [[nodiscard]] const Service& service(ServiceId id) const;
  [[nodiscard]] const Object& object(ObjectId id) const;
  [[nodiscard]] std::optional<ServiceId> find_service(std::string_view name) const;
  [[nodiscard]] std::optional<ObjectId> find_object(std::string_view name) const;

  // What `service` holds on `object` in `mode` (grants of one triple never overlap, see load_policy).
  [[nodiscard]] const Cell& cell(ServiceId service, ObjectId object, SrMode mode) const;
  [[nodiscard]] Rights rights(ServiceId service, ObjectId object, SrMode mode) const {
    return cell(service, object, mode).rights;
  }
  // Union of the rights over every mode.
  [[nodiscard]] Rights rights_any_mode(ServiceId service, ObjectId object) const;

  // Network-facing (docs/design.md §4 `persistent`, `lateral`): declared so, or holding any Network right in any
  // mode — a service that can receive from the network can be compromised from it.
  [[nodiscard]] bool is_network_facing(ServiceId service) const;

 private:
  friend class PolicyBuilder;
  [[nodiscard]] std::size_t cell_index(ServiceId s, ObjectId o, SrMode m) const;
  std::string name_;
  std::string file_;
  std::vector<Service> services_;
  std::vector<Object> objects_;
  std::vector<Grant> grants_;
  std::vector<DenyRule> deny_;
  std::vector<DeclaredType> types_;
  std::vector<Cell> cells_;  // [service][object][mode], dense
};

// Reads, parses and validates a policy file with the fragments it includes (`include`) and `extra` ones
// (a launch graph's `policy_include`), merged as kernel_sim/textproto "Composition" says. CannotRead /
// Syntax / Semantic errors at the file:line:column of the fragment concerned; never an exception.
[[nodiscard]] Result<Policy, LoadError> load_policy(const std::filesystem::path& path,
                                                    std::span<const ExtraFragment> extra = {});
// The same from text; `name` stands for the file in messages and anchors its includes (tests, fuzzing).
[[nodiscard]] Result<Policy, LoadError> parse_policy(std::string_view text, std::string name);

// The kernel's per-mode table (docs/design.md §3): ServiceId and ObjectId are declaration order; each service
// gets one fixed slot per object it is granted in any mode, in object declaration order from slot 1
// (slot 0 stays empty: the null CPtr).
[[nodiscard]] cap::ModeTable compile(const Policy& policy);

}  // namespace rejuv::policy
