// The policy audit (docs/design.md §4): checks a policy against the run-time requirements of §III of the paper
// and against its own `deny` rules, optionally together with the launch graph that will run under it.
// Each finding names the invariant, says what is wrong in the user's terms and points at the grant (or
// launch entry) to change. The kernel refuses to start a graph whose policy has any finding.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/textproto/textproto.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::policy {

// The invariants of docs/design.md §4 (ids as printed: timer, sei, limits, persistent, lateral, checkpoint, mode,
// restricted, controls, coverage) plus the policy's own deny rules (printed as deny:<rule id>).
enum class Invariant : std::uint8_t {
  Timer,
  Sei,
  Limits,
  Persistent,
  Lateral,
  Checkpoint,  // the rejuvenation service can take checkpoints (and an SR graph has one)
  Mode,        // no mode switch within the network's reach in MC
  Restricted,  // the limits Ū bind in MC: a driver reads them there
  Controls,    // the mission controller does not drive in the secure interval
  Coverage,
  Deny,
  Hosts  // the graph across hosts (docs/across_hosts.md), printed as hosts:<rule>
};
inline constexpr std::array kAllInvariants{Invariant::Timer,      Invariant::Sei,      Invariant::Limits,
                                           Invariant::Persistent, Invariant::Lateral,  Invariant::Checkpoint,
                                           Invariant::Mode,       Invariant::Restricted, Invariant::Controls,
                                           Invariant::Coverage,   Invariant::Deny,     Invariant::Hosts};
[[nodiscard]] std::string_view to_string(Invariant invariant);

struct Finding {
  Invariant invariant;
  std::string rule;  // Deny only: the id of the rule that matched
  std::string message;
  SourceLocation where;  // the offending grant, or the launch entry for graph-side problems

  // "timer", ..., "deny:<rule>".
  [[nodiscard]] std::string id() const;
  // "file:line:column: violation [id]: message" (the format compilers use, so editors can jump to it).
  [[nodiscard]] std::string to_string() const;
};

// Checks the policy on its own. Findings are ordered by file, line and column.
[[nodiscard]] std::vector<Finding> audit(const Policy& policy);
// Also checks it against a launch graph: names on both sides, uses vs grants, readers vs writers.
[[nodiscard]] std::vector<Finding> audit(const Policy& policy, const launch::LoadedLaunch& graph);

// Every object a launch graph's service `uses` is an object of the policy. An unknown name is refused as a load
// error at the launch file's line, with the object it most likely meant (README "Exit codes": an unknown name is
// refused, exit 2, not an audit finding); run it before `audit`, which reports the same as a finding.
[[nodiscard]] Result<void, LoadError> check_used_objects(const Policy& policy, const launch::LoadedLaunch& graph);

// One row of the service × object × mode matrix: a pair with a grant in at least one mode.
struct MatrixRow {
  ServiceId service;
  ObjectId object;
  std::array<Rights, kModeCount> rights;  // by index_of(mode)
};
// Rows in service declaration order, then object declaration order.
[[nodiscard]] std::vector<MatrixRow> matrix(const Policy& policy);

}  // namespace rejuv::policy
