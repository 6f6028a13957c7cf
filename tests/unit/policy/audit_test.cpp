// The policy audit (docs/design.md §4): each invariant of §III is caught on a minimal grant and not raised on
// its legitimate neighbour; the shipped policies audit clean and every shipped *_broken example fails
// exactly the invariant its name announces, at the lines its author marked.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <string_view>

#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::policy {
namespace {

const std::filesystem::path kRepo(REJUV_SOURCE_DIR);

std::string ids(const std::vector<Finding>& findings) {
  std::string s;
  for (const Finding& f : findings) {
    s += f.to_string() + "\n";
  }
  return s;
}

bool has(const std::vector<Finding>& findings, std::string_view id) {
  return std::any_of(findings.begin(), findings.end(), [&](const Finding& f) { return f.id() == id; });
}

Policy must_parse(std::string_view text) {
  auto p = parse_policy(text, "mem.policy.pbtxt");
  EXPECT_TRUE(p.has_value()) << p.error().to_string();
  REJUV_ASSERT(p.has_value(), "test policy must parse");
  return std::move(*p);
}

// A clean policy with one of every role; tests append one grant to it.
constexpr std::string_view kBase = R"pb(name: "base"
services { name: "app" }
services { name: "rejuv" rejuvenation: true }
services { name: "drv" level: DRIVER }
services { name: "link" network_facing: true }
objects { name: "data" kind: TOPIC type: "T" }
objects { name: "controls" kind: TOPIC type: "T" role: ACTUATOR }
objects { name: "setpoint" kind: TOPIC type: "T" role: SETPOINT }
objects { name: "checkpoint" kind: CHECKPOINT }
objects { name: "net" kind: NETWORK }
objects { name: "limits" kind: LIMITS }
objects { name: "cell" kind: PERSISTENT size_bytes: 4 }
grants { service: "app" object: "data" rights: "RW" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "app" object: "controls" rights: "W" modes: [MC] }
grants { service: "app" object: "setpoint" rights: "RW" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "rejuv" object: "checkpoint" rights: "W" modes: [RB, SC, UPDATE, CP] }
grants { service: "rejuv" object: "limits" rights: "W" modes: [RB, SC, UPDATE, CP] }
grants { service: "rejuv" object: "cell" rights: "RW" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "drv" object: "controls" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "drv" object: "limits" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "link" object: "net" rights: "RW" modes: [MC] }
grants { service: "link" object: "data" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
)pb";
constexpr int kBaseLines = 22;  // the appended grant is on line 23

std::vector<Finding> audit_with(std::string_view extra) {
  return audit(must_parse(std::string(kBase) + std::string(extra)));
}

// The appended grant violates exactly `id`, and the finding points at it.
void expect_only(std::string_view extra, std::string_view id) {
  const auto f = audit_with(extra);
  ASSERT_FALSE(f.empty()) << "no finding for: " << extra;
  for (const Finding& x : f) {
    EXPECT_EQ(x.id(), id) << ids(f);
    EXPECT_EQ(x.where.line, kBaseLines + 1) << ids(f);
    EXPECT_EQ(x.where.column, 1) << ids(f);
    EXPECT_EQ(x.where.file, "mem.policy.pbtxt");
  }
}

void expect_clean(std::string_view extra) {
  const auto f = audit_with(extra);
  EXPECT_TRUE(f.empty()) << ids(f);
}

TEST(Audit, BasePolicy_Clean) {
  expect_clean("");
}

// ---- timer (§III protection of the timing mechanism) ----
TEST(AuditTimer, CheckpointWriteInMc_Finding) {
  expect_only("grants { service: \"rejuv\" object: \"checkpoint\" rights: \"R\" modes: [MC] }\n", "timer");
}
TEST(AuditTimer, CheckpointReadInMc_AlsoFinding) {
  // Any right in MC: even reading the timer's state reaches the Checkpoint module while vulnerable.
  const auto f = audit_with("grants { service: \"app\" object: \"checkpoint\" rights: \"R\" modes: [MC] }\n");
  EXPECT_TRUE(has(f, "timer")) << ids(f);
}
TEST(AuditTimer, CheckpointOutsideMc_Clean) {
  expect_clean("grants { service: \"app\" object: \"checkpoint\" rights: \"R\" modes: [SC] }\n");
}

// ---- sei (§III secure execution interval) ----
TEST(AuditSei, NetworkInUpdate_Finding) {
  expect_only("grants { service: \"drv\" object: \"net\" rights: \"R\" modes: [UPDATE] }\n", "sei");
}
TEST(AuditSei, NetworkInRb_Finding) {
  expect_only("grants { service: \"drv\" object: \"net\" rights: \"W\" modes: [RB] }\n", "sei");
}
TEST(AuditSei, FindingNamesOnlyTheBadModes) {
  const auto f = audit(must_parse(std::string(kBase).replace(
      std::string(kBase).find("rights: \"RW\" modes: [MC] }"), 26, "rights: \"RW\" modes: [MC, CP] }")));
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "sei");
  EXPECT_NE(f[0].message.find("in CP"), std::string::npos) << f[0].message;
}

// ---- limits (§III limits on control uncertainty, §IV-C) ----
TEST(AuditLimits, WriteInMcByRejuvenation_Finding) {
  // Adds MC in front of the rejuvenation service's Limits grant, leaving its other modes as they are.
  constexpr std::string_view kFrom = "\"limits\" rights: \"W\" modes: [RB";
  std::string text(kBase);
  text.replace(text.find(kFrom), kFrom.size(), "\"limits\" rights: \"W\" modes: [MC, RB");
  const auto f = audit(must_parse(text));
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "limits");
  EXPECT_NE(f[0].message.find("in MC"), std::string::npos);
}
TEST(AuditLimits, WriteByApplication_Finding) {
  expect_only("grants { service: \"app\" object: \"limits\" rights: \"W\" modes: [SC] }\n", "limits");
}
TEST(AuditLimits, WriteByApplicationInMc_TwoFindings) {
  const auto f = audit_with("grants { service: \"app\" object: \"limits\" rights: \"W\" modes: [MC] }\n");
  EXPECT_EQ(std::count_if(f.begin(), f.end(), [](const Finding& x) { return x.id() == "limits"; }), 2)
      << ids(f);
}
TEST(AuditLimits, ReadByApplication_Finding) {
  expect_only("grants { service: \"app\" object: \"limits\" rights: \"R\" modes: [MC] }\n", "limits");
}
TEST(AuditLimits, ReadByRejuvenationService_Finding) {
  // The rejuvenation service writes Ū; applying it is the driver's job alone.
  expect_only("grants { service: \"rejuv\" object: \"limits\" rights: \"R\" modes: [MC] }\n", "limits");
}

// ---- persistent (§III persistent data) ----
TEST(AuditPersistent, DeclaredNetworkFacingWritesInMc_Finding) {
  expect_only("grants { service: \"link\" object: \"cell\" rights: \"W\" modes: [MC] }\n", "persistent");
}
TEST(AuditPersistent, ImpliedNetworkFacingWritesInMc_Finding) {
  const auto f = audit_with(
      "grants { service: \"drv\" object: \"cell\" rights: \"W\" modes: [MC] }\n"
      "grants { service: \"drv\" object: \"net\" rights: \"R\" modes: [MC] }\n");
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "persistent");
  EXPECT_EQ(f[0].where.line, kBaseLines + 1);
}
TEST(AuditPersistent, NetworkFacingWritesOutsideMc_Clean) {
  expect_clean("grants { service: \"link\" object: \"cell\" rights: \"W\" modes: [SC, CP] }\n");
}
TEST(AuditPersistent, NetworkFacingReadsInMc_Clean) {
  expect_clean("grants { service: \"link\" object: \"cell\" rights: \"R\" modes: [MC] }\n");
}

// ---- lateral (docs/design.md §4) ----
TEST(AuditLateral, NetworkFacingPublishesActuator_Finding) {
  expect_only("grants { service: \"link\" object: \"controls\" rights: \"W\" modes: [MC] }\n", "lateral");
}
TEST(AuditLateral, NetworkFacingPublishesSetpointOutsideMc_Finding) {
  // The service stays network-facing in every mode: a compromise in MC persists until the rollback.
  expect_only("grants { service: \"link\" object: \"setpoint\" rights: \"W\" modes: [SC] }\n", "lateral");
}
TEST(AuditLateral, NetworkFacingReadsSetpoint_Clean) {
  expect_clean("grants { service: \"link\" object: \"setpoint\" rights: \"R\" modes: [MC] }\n");
}
TEST(AuditLateral, NetworkFacingPublishesData_Clean) {
  expect_clean(
      "objects { name: \"upload\" kind: TOPIC type: \"T\" }\n"
      "grants { service: \"link\" object: \"upload\" rights: \"W\" modes: [MC] }\n"
      "grants { service: \"app\" object: \"upload\" rights: \"R\" modes: [MC] }\n");
}

// ---- coverage, policy side ----
TEST(AuditCoverage, ServiceWithoutGrant_FindingAtService) {
  const auto f = audit(must_parse(std::string(kBase) + "services { name: \"idle\" }\n"));
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "coverage");
  EXPECT_EQ(f[0].where.line, kBaseLines + 1);
}
TEST(AuditCoverage, ObjectWithoutGrant_Finding) {
  const auto f = audit(must_parse(std::string(kBase) + "objects { name: \"idle\" kind: MODE }\n"));
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "coverage");
}
TEST(AuditCoverage, KernelSubscribedObjectWithoutGrant_Clean) {
  expect_clean("objects { name: \"truth\" kind: TOPIC type: \"T\" kernel: KERNEL_SUBSCRIBES }\n");
}
TEST(AuditCoverage, ServiceWritesKernelPublishedTopic_Finding) {
  const auto f =
      audit(must_parse(std::string(kBase) +
                       "objects { name: \"mode\" kind: TOPIC type: \"T\" kernel: KERNEL_PUBLISHES }\n"
                       "grants { service: \"app\" object: \"mode\" rights: \"RW\" modes: [SC] }\n"));
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "coverage");
  EXPECT_NE(f[0].message.find("forge"), std::string::npos);
}

// ---- deny rules ----
TEST(AuditDeny, MatchingGrant_FindingNamedAfterRule) {
  const auto f = audit_with(
      "deny { id: \"no-app-controls\" service: \"app\" object: \"controls\" rights: \"W\" reason: \"why\" "
      "}\n");
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "deny:no-app-controls");
  EXPECT_EQ(f[0].where.line, 14);  // the app → controls grant
  EXPECT_NE(f[0].message.find("why"), std::string::npos);
}
TEST(AuditDeny, ExceptServices_Honoured) {
  expect_clean("deny { id: \"net\" service: \"*\" object: \"*\" kind: NETWORK except_services: \"link\" }\n");
}
TEST(AuditDeny, WildcardWithoutException_MatchesEveryHolder) {
  const auto f = audit_with("deny { id: \"nolimits\" service: \"*\" object: \"limits\" }\n");
  EXPECT_EQ(f.size(), 2U) << ids(f);  // rejuv W, drv R
}
TEST(AuditDeny, RightsFilter_OnlyMatchingRights) {
  const auto f = audit_with("deny { id: \"nowrite\" service: \"*\" object: \"limits\" rights: \"W\" }\n");
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].where.line, 17);  // rejuv → limits
}
TEST(AuditDeny, ModesFilter_OnlyMatchingModes) {
  expect_clean("deny { id: \"mc\" service: \"*\" object: \"checkpoint\" modes: [MC] }\n");
  const auto f = audit_with("deny { id: \"cp\" service: \"*\" object: \"checkpoint\" modes: [CP] }\n");
  EXPECT_EQ(f.size(), 1U) << ids(f);
}
TEST(AuditDeny, KindFilter_OnlyThatKind) {
  const auto f = audit_with("deny { id: \"noper\" service: \"rejuv\" object: \"*\" kind: PERSISTENT }\n");
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].where.line, 18);  // rejuv → cell
}

// ---- the shipped policies ----

TEST(AuditShipped, QuadSr_Clean) {
  const auto p = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const auto f = audit(*p);
  EXPECT_TRUE(f.empty()) << ids(f);
}

TEST(AuditShipped, QuadSrWithQuadSquareLaunch_Clean) {
  const auto p = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const auto g = launch::load_launch(kRepo / "launch" / "quad_square_paper.launch.pbtxt");
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto f = audit(*p, *g);
  EXPECT_TRUE(f.empty()) << ids(f);
}

TEST(AuditShipped, QuadSr_StatesTheInvariantsOfDesign8) {
  const auto p = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const auto rights = [&](std::string_view s, std::string_view o, SrMode m) {
    return p->rights(*p->find_service(s), *p->find_object(o), m);
  };
  EXPECT_EQ(rights("ext_link", "ext_net", SrMode::MC), Rights(Right::Read) | Right::Write);
  EXPECT_TRUE(rights("ext_link", "ext_net", SrMode::SC).empty());
  EXPECT_TRUE(rights("lqr_control", "actuator_controls", SrMode::MC).has(Right::Write));
  EXPECT_FALSE(rights("lqr_control", "actuator_controls", SrMode::SC).has(Right::Write));
  EXPECT_TRUE(rights("safety_control", "actuator_controls", SrMode::SC).has(Right::Write));
  EXPECT_FALSE(rights("safety_control", "actuator_controls", SrMode::MC).has(Right::Write));
  EXPECT_TRUE(rights("checkpoint_p", "checkpoint", SrMode::MC).empty());
  EXPECT_TRUE(rights("output_driver", "actuator_limits", SrMode::MC).has(Right::Read));
}

// Lines of `path` that carry `marker` after some content (header comments that mention it do not count).
std::set<int> marked_lines(const std::filesystem::path& path, std::string_view marker) {
  std::ifstream in(path);
  std::set<int> lines;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.find(marker) != std::string::npos && !line.starts_with("#")) {
      lines.insert(n);
    }
  }
  return lines;
}

// Each policies/examples/<invariant>_broken*.policy.pbtxt violates that invariant and nothing else, at
// exactly the lines marked "<- violation".
TEST(AuditShipped, BrokenExamples_FailTheirNamedInvariantOnly) {
  std::set<std::string> covered;
  for (const auto& entry : std::filesystem::directory_iterator(kRepo / "policies" / "examples")) {
    const std::string name = entry.path().filename().string();
    const std::size_t cut = name.find("_broken");
    if (cut == std::string::npos) {
      continue;
    }
    const std::string invariant = name.substr(0, cut);
    covered.insert(invariant);
    SCOPED_TRACE(name);
    const auto p = load_policy(entry.path());
    ASSERT_TRUE(p.has_value()) << p.error().to_string();
    const auto f = audit(*p);
    ASSERT_FALSE(f.empty()) << "audits clean";
    std::set<int> lines;
    for (const Finding& x : f) {
      const std::string id = x.id();
      EXPECT_TRUE(id == invariant || (invariant == "deny" && id.starts_with("deny:"))) << ids(f);
      lines.insert(x.where.line);
    }
    EXPECT_EQ(lines, marked_lines(entry.path(), "<- violation")) << ids(f);
  }
  for (const Invariant inv : kAllInvariants) {
    if (inv == Invariant::Hosts) continue;  // graph-side only: a policy alone places nothing (hosts_test.cpp)
    EXPECT_TRUE(covered.contains(std::string(to_string(inv)))) << "no broken example for " << to_string(inv);
  }
}

TEST(AuditShipped, GoodExamples_Clean) {
  int seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kRepo / "policies" / "examples")) {
    const std::string name = entry.path().filename().string();
    if (name.find("broken") != std::string::npos || name.starts_with("malformed_") ||
        !name.ends_with(".policy.pbtxt")) {
      continue;
    }
    ++seen;
    const auto p = load_policy(entry.path());
    ASSERT_TRUE(p.has_value()) << p.error().to_string();
    const auto f = audit(*p);
    EXPECT_TRUE(f.empty()) << name << "\n" << ids(f);
  }
  EXPECT_GE(seen, 1);
}

// ---- coverage against a launch graph ----

constexpr std::string_view kGraphPolicy =
    R"pb(name: "graph"
services { name: "est" }
services { name: "ctl" }
services { name: "drv" level: DRIVER }
objects { name: "sensors" kind: TOPIC type: "T" }
objects { name: "state" kind: TOPIC type: "T" }
objects { name: "controls" kind: TOPIC type: "T" role: ACTUATOR }
objects { name: "outputs" kind: TOPIC type: "T" role: ACTUATOR }
grants { service: "est" object: "sensors" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "est" object: "state" rights: "W" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "ctl" object: "state" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "ctl" object: "controls" rights: "W" modes: [MC] }
grants { service: "drv" object: "controls" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "drv" object: "outputs" rights: "W" modes: [MC, RB, SC, UPDATE, CP] }
)pb";

constexpr std::string_view kGraph = R"pb(name: "g"
policy: "../policies/examples/minimal.policy.pbtxt"
services {
  name: "est"
  executable: "e"
  uses { object: "sensors" rights: "R" }
  uses { object: "state" rights: "W" }
}
services {
  name: "ctl"
  executable: "c"
  uses { object: "state" rights: "R" }
  uses { object: "controls" rights: "W" }
}
services {
  name: "drv"
  executable: "d"
  rejuvenate: false
  uses { object: "controls" rights: "R" }
  uses { object: "outputs" rights: "W" }
}
dds {
  bridges { topic: "sensors" direction: BRIDGE_IN }
  bridges { topic: "outputs" direction: BRIDGE_OUT }
}
mission {
  waypoints { down_m: -1 }
  acceptance_radius_m: 0.1
  timeout_s: 10
}
)pb";

std::string replaced(std::string_view text, std::string_view from, std::string_view to) {
  std::string s(text);
  const std::size_t at = s.find(from);
  REJUV_ASSERT(at != std::string::npos, "test bug: text to replace not found");
  return s.replace(at, from.size(), to);
}

std::vector<Finding> audit_graph(std::string_view policy_text, std::string_view graph_text) {
  const Policy p = must_parse(policy_text);
  const auto g = launch::parse_launch(graph_text, kRepo / "launch" / "unit_graph.launch.pbtxt");
  EXPECT_TRUE(g.has_value()) << g.error().to_string();
  REJUV_ASSERT(g.has_value(), "test graph must load");
  return audit(p, *g);
}

void expect_one_coverage(const std::vector<Finding>& f, std::string_view file_part, int line,
                         std::string_view part) {
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "coverage");
  EXPECT_NE(f[0].where.file.find(file_part), std::string::npos) << ids(f);
  EXPECT_EQ(f[0].where.line, line) << ids(f);
  EXPECT_NE(f[0].message.find(part), std::string::npos) << ids(f);
}

TEST(AuditGraph, MatchingGraph_Clean) {
  const auto f = audit_graph(kGraphPolicy, kGraph);
  EXPECT_TRUE(f.empty()) << ids(f);
}

TEST(AuditGraph, LaunchServiceNotInPolicy_FindingInLaunchFile) {
  const auto f = audit_graph(kGraphPolicy, replaced(kGraph, "name: \"ctl\"", "name: \"ctl2\""));
  // ctl2 is unknown (launch line 10) and the policy's ctl is missing from the graph (policy line 3).
  ASSERT_EQ(f.size(), 2U) << ids(f);
  EXPECT_TRUE(std::all_of(f.begin(), f.end(), [](const Finding& x) { return x.id() == "coverage"; }))
      << ids(f);
  const bool launch_side = std::any_of(f.begin(), f.end(), [](const Finding& x) {
    return x.where.file.ends_with("unit_graph.launch.pbtxt") && x.where.line == 10 &&
           x.message.ends_with("(did you mean \"ctl\"?)");  // a typo of a declared name is named
  });
  const bool policy_side = std::any_of(f.begin(), f.end(), [](const Finding& x) {
    return x.where.file == "mem.policy.pbtxt" && x.where.line == 3;
  });
  EXPECT_TRUE(launch_side && policy_side) << ids(f);
}

TEST(AuditGraph, UseNotGranted_FindingAtUse) {
  const auto f = audit_graph(kGraphPolicy, replaced(kGraph, "uses { object: \"state\" rights: \"R\" }",
                                                    "uses { object: \"state\" rights: \"RW\" }"));
  expect_one_coverage(f, "unit_graph", 12, "grants only \"R\"");
}

TEST(AuditGraph, UseOfUnknownObject_Finding) {
  const auto f = audit_graph(kGraphPolicy, replaced(kGraph, "  uses { object: \"controls\" rights: \"W\" }\n",
                                                    "  uses { object: \"controls\" rights: \"W\" }\n"
                                                    "  uses { object: \"nothing\" rights: \"R\" }\n"));
  expect_one_coverage(f, "unit_graph", 14, "not an object of the policy");
}

TEST(CheckUsedObjects, MisspeltObject_LoadErrorAtTheUseWithSuggestion) {
  const Policy p = must_parse(kGraphPolicy);
  const auto g = launch::parse_launch(
      replaced(kGraph, "uses { object: \"controls\" rights: \"W\" }", "uses { object: \"control\" rights: \"W\" }"),
      kRepo / "launch" / "unit_graph.launch.pbtxt");
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto r = check_used_objects(p, *g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, 13) << r.error().to_string();
  EXPECT_NE(r.error().message.find("uses \"control\", which is no object of the policy"), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("(did you mean \"controls\"?)"), std::string::npos) << r.error().message;
}

TEST(CheckUsedObjects, EveryObjectDeclared_Accepted) {
  const Policy p = must_parse(kGraphPolicy);
  const auto g = launch::parse_launch(kGraph, kRepo / "launch" / "unit_graph.launch.pbtxt");
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  EXPECT_TRUE(check_used_objects(p, *g).has_value());
}

TEST(AuditGraph, GrantNotUsed_DeadGrantFinding) {
  const auto f = audit_graph(
      replaced(kGraphPolicy, "rights: \"W\" modes: [MC] }\ngrants { service: \"drv\"",
               "rights: \"RW\" modes: [MC] }\ngrants { service: \"drv\""),
      kGraph);
  expect_one_coverage(f, "mem.policy", 12, "dead grant");
}

TEST(AuditGraph, GrantOfUnusedObject_DeadGrantFinding) {
  const auto f =
      audit_graph(std::string(kGraphPolicy) +
                      "grants { service: \"ctl\" object: \"sensors\" rights: \"R\" modes: [SC] }\n",
                  kGraph);
  expect_one_coverage(f, "mem.policy", 15, "does not use \"sensors\"");
}

TEST(AuditGraph, TopicReadWithoutWriter_Finding) {
  // No bridge IN for sensors: est reads a topic nobody writes.
  const auto f = audit_graph(kGraphPolicy,
                             replaced(kGraph, "  bridges { topic: \"sensors\" direction: BRIDGE_IN }\n", ""));
  expect_one_coverage(f, "mem.policy", 9, "nobody writes it");
}

TEST(AuditGraph, TopicWrittenWithoutReader_Finding) {
  const auto f = audit_graph(
      kGraphPolicy, replaced(kGraph, "  bridges { topic: \"outputs\" direction: BRIDGE_OUT }\n", ""));
  expect_one_coverage(f, "mem.policy", 14, "nobody reads it");
}

TEST(AuditGraph, KernelPublishedTopic_NeedsNoWriter) {
  const auto f =
      audit_graph(replaced(kGraphPolicy, "objects { name: \"sensors\" kind: TOPIC type: \"T\" }",
                           "objects { name: \"sensors\" kind: TOPIC type: \"T\" kernel: KERNEL_PUBLISHES }"),
                  replaced(kGraph, "  bridges { topic: \"sensors\" direction: BRIDGE_IN }\n", ""));
  EXPECT_TRUE(f.empty()) << ids(f);
}

TEST(AuditGraph, BridgeOfUnknownTopic_FindingAtBridge) {
  const auto f =
      audit_graph(kGraphPolicy, replaced(kGraph, "dds {\n", "dds {\n  bridges { topic: \"ghost\" }\n"));
  expect_one_coverage(f, "unit_graph", 23, "not a topic of the policy");
}

TEST(AuditGraph, DriverLevelMismatch_Finding) {
  const auto f = audit_graph(kGraphPolicy, replaced(kGraph, "  rejuvenate: false\n", ""));
  expect_one_coverage(f, "unit_graph", 16, "level: DRIVER");
}


// ---- checkpoint, mode, restricted, controls: holes that audited clean without deny rules ----

std::vector<Finding> audit_text(std::string_view text) { return audit(must_parse(text)); }

void expect_only_at(const std::vector<Finding>& f, std::string_view id, int line) {
  ASSERT_FALSE(f.empty()) << "no finding";
  for (const Finding& x : f) {
    EXPECT_EQ(x.id(), id) << ids(f);
    EXPECT_EQ(x.where.line, line) << ids(f);
  }
}

TEST(AuditCheckpoint, RejuvenationServiceWithoutCheckpointObject_FindingAtService) {
  std::string text = replaced(kBase, "objects { name: \"checkpoint\" kind: CHECKPOINT }\n", "");
  text = replaced(text, "grants { service: \"rejuv\" object: \"checkpoint\" rights: \"W\" modes: [RB, SC, UPDATE, CP] }\n", "");
  expect_only_at(audit_text(text), "checkpoint", 3);  // services { name: "rejuv" rejuvenation: true }
}
TEST(AuditCheckpoint, CheckpointReadOnly_Finding) {
  const std::string text = replaced(kBase, "object: \"checkpoint\" rights: \"W\"", "object: \"checkpoint\" rights: \"R\"");
  expect_only_at(audit_text(text), "checkpoint", 3);
}
TEST(AuditCheckpoint, SrGraphWithoutRejuvenationService_FindingAtSrEnabled) {
  const std::string sr =
      "sr {\n  enabled: true\n  t_mc_s: 0.3 t_est_s: 3 rho_m: 0.1 rho_s: 0.05\n"
      "  box { position_m: 0.5 velocity_m_s: 1 angle_rad: 0.3 rate_rad_s: 2 }\n  restricted_limit_fraction: 0.3\n}\n";
  const std::string graph = std::string(kGraph) + sr;
  const int sr_line = static_cast<int>(std::count(graph.begin(), graph.begin() + static_cast<long>(graph.find("enabled: true")), '\n')) + 1;
  const auto f = audit_graph(kGraphPolicy, graph);
  ASSERT_EQ(f.size(), 1U) << ids(f);
  EXPECT_EQ(f[0].id(), "checkpoint");
  EXPECT_NE(f[0].where.file.find("unit_graph.launch.pbtxt"), std::string::npos) << ids(f);
  EXPECT_EQ(f[0].where.line, sr_line) << ids(f);
  // The same graph without SR needs no rejuvenation service.
  EXPECT_TRUE(audit_graph(kGraphPolicy, kGraph).empty());
}

constexpr std::string_view kModeObject = "objects { name: \"mode\" kind: MODE }\n";
TEST(AuditMode, NetworkFacingServiceHoldsModeInMc_Finding) {
  const auto f = audit_text(std::string(kBase) + std::string(kModeObject) +
                            "grants { service: \"link\" object: \"mode\" rights: \"W\" modes: [MC] }\n"
                            "grants { service: \"rejuv\" object: \"mode\" rights: \"W\" modes: [SC] }\n");
  expect_only_at(f, "mode", kBaseLines + 2);
}
TEST(AuditMode, RejuvenationServiceHoldsModeInSei_Clean) {
  const auto f = audit_text(std::string(kBase) + std::string(kModeObject) +
                            "grants { service: \"rejuv\" object: \"mode\" rights: \"W\" modes: [RB, SC, UPDATE, CP] }\n");
  EXPECT_TRUE(f.empty()) << ids(f);
}

TEST(AuditRestricted, DriverReadsLimitsOnlyInSei_FindingAtTheRead) {
  const std::string text = replaced(kBase, "grants { service: \"drv\" object: \"limits\" rights: \"R\" modes: [MC, RB, SC, UPDATE, CP] }",
                                    "grants { service: \"drv\" object: \"limits\" rights: \"R\" modes: [RB, SC, UPDATE, CP] }");
  expect_only_at(audit_text(text), "restricted", 20);
}
TEST(AuditRestricted, LimitsWrittenButReadByNoDriver_FindingAtTheWrite) {
  const std::string text = replaced(kBase, "grants { service: \"drv\" object: \"limits\" rights: \"R\" modes: [MC, RB, SC, UPDATE, CP] }\n", "");
  expect_only_at(audit_text(text), "restricted", 17);  // rejuv → limits
}

TEST(AuditControls, MissionControllerAlsoDrivesInSc_Finding) {
  const std::string text = replaced(kBase, "grants { service: \"app\" object: \"controls\" rights: \"W\" modes: [MC] }",
                                    "grants { service: \"app\" object: \"controls\" rights: \"W\" modes: [MC, SC] }");
  const auto f = audit_text(text);
  expect_only_at(f, "controls", 14);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_NE(f[0].message.find("in SC"), std::string::npos) << ids(f);
}
TEST(AuditControls, SafetyControllerDrivesOnlyInSei_Clean) {
  const auto f = audit_with("grants { service: \"link\" object: \"controls\" rights: \"W\" modes: [SC] }\n");
  // link is network-facing: `lateral` objects to it, `controls` does not (it does not drive in MC).
  EXPECT_FALSE(has(f, "controls")) << ids(f);
}

}  // namespace
}  // namespace rejuv::policy
