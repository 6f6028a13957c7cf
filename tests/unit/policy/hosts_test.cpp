// The graph across hosts (docs/across_hosts.md): the launch graph's `hosts` and each service's `host` are
// checked at load; the `hosts` audit refuses a topic crossing hosts outside MC, a service of the secure
// interval off the vehicle, and a remote writer of a steering topic the policy does not name; each host's DDS
// topics are exactly the crossings of the policy. Fixture: tests/across_hosts/companion.{policy,launch}.pbtxt.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>

#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/hosts.hpp"
#include "rejuv/policy/policy.hpp"
#include "companion_files.hpp"

namespace rejuv::policy {
namespace {

using companion::all;
using companion::read;
using companion::replaced;
const std::filesystem::path& kDir = companion::kCompanionDir;

int line_of(const std::string& text, std::string_view what) {
  const std::size_t at = text.find(what);
  REJUV_ASSERT(at != std::string::npos, "test bug: line not found");
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

const std::string kPolicy = read(kDir / "companion.policy.pbtxt");
const std::string kGraph = read(kDir / "companion.launch.pbtxt");

struct Loaded {
  Policy policy;
  launch::LoadedLaunch graph;
};

Loaded load(const std::string& policy_text, const std::string& graph_text) {
  auto p = parse_policy(policy_text, "companion.policy.pbtxt");
  EXPECT_TRUE(p.has_value()) << p.error().to_string();
  REJUV_ASSERT(p.has_value(), "test policy must parse");
  auto g = launch::parse_launch(graph_text, kDir / "companion.launch.pbtxt");
  EXPECT_TRUE(g.has_value()) << g.error().to_string();
  REJUV_ASSERT(g.has_value(), "test graph must load");
  return Loaded{std::move(*p), std::move(*g)};
}

std::vector<Finding> audit_texts(const std::string& policy_text, const std::string& graph_text) {
  const Loaded l = load(policy_text, graph_text);
  return audit(l.policy, l.graph);
}

TEST(HostsAudit, CompanionGraph_Clean) {
  const auto f = audit_texts(kPolicy, kGraph);
  EXPECT_TRUE(f.empty()) << all(f);
}

TEST(HostsAudit, CrossHostReadInSecureInterval_RefusedAtTheRemoteGrant) {
  const std::string from = "grants { service: \"monitor\" object: \"state\" rights: \"R\" modes: [MC] }";
  const std::string policy = replaced(kPolicy, from, "grants { service: \"monitor\" object: \"state\" rights: \"R\" modes: [MC, SC] }");
  const auto f = audit_texts(policy, kGraph);
  ASSERT_EQ(f.size(), 1U) << all(f);
  EXPECT_EQ(f[0].id(), "hosts:mc-only");
  EXPECT_EQ(f[0].where.line, line_of(kPolicy, from));
  EXPECT_NE(f[0].message.find("topic \"state\" crosses from host \"vehicle\" (\"est\" writes it) to host \"companion\" "
                              "(\"monitor\" reads it) in SC"),
            std::string::npos)
      << f[0].message;
}

TEST(HostsAudit, CrossHostWriteInSecureInterval_Refused) {
  const std::string from = "grants { service: \"planner\" object: \"waypoints\" rights: \"W\" modes: [MC] }";
  const std::string policy =
      replaced(kPolicy, from, "grants { service: \"planner\" object: \"waypoints\" rights: \"W\" modes: [MC, UPDATE] }");
  const auto f = audit_texts(policy, kGraph);
  const auto it = std::find_if(f.begin(), f.end(), [](const Finding& x) { return x.id() == "hosts:mc-only"; });
  ASSERT_NE(it, f.end()) << all(f);
  // The grant off the vehicle is the one to change: the planner's.
  EXPECT_EQ(it->where.line, line_of(kPolicy, from));
  EXPECT_NE(it->message.find("from host \"companion\" (\"planner\" writes it) to host \"vehicle\" (\"commander\" "
                             "reads it) in UPDATE"),
            std::string::npos)
      << it->message;
  // A planner that writes in UPDATE acts in the secure interval: it belongs on the vehicle as well.
  EXPECT_TRUE(std::any_of(f.begin(), f.end(), [](const Finding& x) { return x.id() == "hosts:vehicle"; })) << all(f);
}

TEST(HostsAudit, SafetyServiceOnCompanion_RefusedAtItsHost) {
  const std::string graph = replaced(kGraph, "  executable: \"s\"\n", "  executable: \"s\"\n  host: \"companion\"\n");
  const auto f = audit_texts(kPolicy, graph);
  const auto vehicle = std::find_if(f.begin(), f.end(), [](const Finding& x) { return x.id() == "hosts:vehicle"; });
  ASSERT_NE(vehicle, f.end()) << all(f);
  EXPECT_EQ(vehicle->where.line, line_of(graph, "  host: \"companion\"\n  uses { object: \"state\" rights: \"R\" }\n  uses { object: \"telemetry\""));
  EXPECT_NE(vehicle->message.find("service \"safety\" acts in the secure interval (it writes in the secure interval) "
                                  "but runs on host \"companion\": it must run on the vehicle's host \"vehicle\""),
            std::string::npos)
      << vehicle->message;
  // Its controls would also cross in the SEI, from a remote writer of an ACTUATOR topic.
  for (const std::string_view id : {"hosts:mc-only", "hosts:remote-writer"}) {
    EXPECT_TRUE(std::any_of(f.begin(), f.end(), [&](const Finding& x) { return x.id() == id; })) << id << "\n" << all(f);
  }
}

TEST(HostsAudit, DriverOnCompanion_Refused) {
  const std::string graph = replaced(kGraph, "  rejuvenate: false\n", "  rejuvenate: false\n  host: \"companion\"\n");
  const auto f = audit_texts(kPolicy, graph);
  EXPECT_TRUE(std::any_of(f.begin(), f.end(), [](const Finding& x) {
    return x.id() == "hosts:vehicle" && x.message.find("\"drv\" acts in the secure interval (it is a driver)") != std::string::npos;
  })) << all(f);
}

TEST(HostsAudit, RejuvenationServiceOnCompanion_Refused) {
  const std::string graph = replaced(kGraph, "  executable: \"r\"\n", "  executable: \"r\"\n  host: \"companion\"\n");
  const auto f = audit_texts(kPolicy, graph);
  EXPECT_TRUE(std::any_of(f.begin(), f.end(), [](const Finding& x) {
    return x.id() == "hosts:vehicle" &&
           x.message.find("\"rejuv\" acts in the secure interval (it is the rejuvenation service)") != std::string::npos;
  })) << all(f);
}

TEST(HostsAudit, RemoteWriterOfSetpointTopic_Refused) {
  const std::string from = "objects { name: \"waypoints\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" }";
  const std::string policy =
      replaced(kPolicy, from, "objects { name: \"waypoints\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" role: SETPOINT }");
  const auto f = audit_texts(policy, kGraph);
  ASSERT_EQ(f.size(), 1U) << all(f);
  EXPECT_EQ(f[0].id(), "hosts:remote-writer");
  EXPECT_NE(f[0].message.find("service \"planner\" on host \"companion\" writes the SETPOINT topic \"waypoints\""),
            std::string::npos)
      << f[0].message;
  EXPECT_TRUE(f[0].where.file.ends_with("companion.launch.pbtxt")) << f[0].to_string();
}

TEST(HostsAudit, RemoteWriterNamedByThePolicy_Accepted) {
  const std::string from = "objects { name: \"waypoints\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" }";
  const std::string policy = replaced(
      kPolicy, from,
      "objects { name: \"waypoints\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" role: SETPOINT remote_writers: \"planner\" }");
  const auto f = audit_texts(policy, kGraph);
  EXPECT_TRUE(f.empty()) << all(f);
}

TEST(HostsPolicy, RemoteWritersOnDataTopic_Refused) {
  const std::string policy = replaced(kPolicy, "type: \"rejuv::msg::MissionWaypoints\" }",
                                      "type: \"rejuv::msg::MissionWaypoints\" remote_writers: \"planner\" }");
  const auto p = parse_policy(policy, "companion.policy.pbtxt");
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("`remote_writers` applies to ACTUATOR or SETPOINT topics"), std::string::npos)
      << p.error().to_string();
}

TEST(HostsPolicy, RemoteWriterUnknownService_Refused) {
  const std::string policy = replaced(kPolicy, "role: SETPOINT }", "role: SETPOINT remote_writers: \"planer\" }");
  const auto p = parse_policy(policy, "companion.policy.pbtxt");
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("unknown service \"planer\" in remote_writers"), std::string::npos)
      << p.error().to_string();
  EXPECT_NE(p.error().message.find("did you mean \"planner\""), std::string::npos) << p.error().to_string();
}

TEST(HostsTopics, EachHostPublishesAndSubscribesExactlyItsCrossings) {
  const Loaded l = load(kPolicy, kGraph);
  const auto t = host_topics(l.policy, placement(l.policy, l.graph), launch::dds_naming(l.graph.graph.dds()));
  ASSERT_EQ(t.size(), 2U);
  EXPECT_EQ(t[0].host, "vehicle");
  EXPECT_EQ(t[0].publish, std::vector<std::string>{"rejuv/state"});
  EXPECT_EQ(t[0].subscribe, std::vector<std::string>{"rejuv/waypoints"});
  EXPECT_EQ(t[1].host, "companion");
  EXPECT_EQ(t[1].publish, std::vector<std::string>{"rejuv/waypoints"});
  EXPECT_EQ(t[1].subscribe, std::vector<std::string>{"rejuv/state"});
}

// A graph with `dds { ros2_names: true }`: the same crossings, under ROS 2's topic names.
TEST(HostsTopics, Ros2NamesGraph_TopicsAreRt) {
  const Loaded l = load(kPolicy, kGraph + "dds { ros2_names: true }\n");
  const DdsNaming naming = launch::dds_naming(l.graph.graph.dds());
  ASSERT_EQ(naming, DdsNaming::Ros2);
  const auto t = host_topics(l.policy, placement(l.policy, l.graph), naming);
  ASSERT_EQ(t.size(), 2U);
  EXPECT_EQ(t[0].host, "vehicle");
  EXPECT_EQ(t[0].publish, std::vector<std::string>{"rt/state"});
  EXPECT_EQ(t[0].subscribe, std::vector<std::string>{"rt/waypoints"});
  EXPECT_EQ(t[1].host, "companion");
  EXPECT_EQ(t[1].publish, std::vector<std::string>{"rt/waypoints"});
  EXPECT_EQ(t[1].subscribe, std::vector<std::string>{"rt/state"});
}

TEST(HostsTopics, CrossHostName_FollowsTheNaming) {
  const Loaded l = load(kPolicy, kGraph);
  const auto state = l.policy.find_object("state");
  ASSERT_TRUE(state.has_value());
  EXPECT_EQ(cross_host_dds_name(l.policy.object(*state), DdsNaming::Rejuv), "rejuv/state");
  EXPECT_EQ(cross_host_dds_name(l.policy.object(*state), DdsNaming::Ros2), "rt/state");
}

TEST(HostsTopics, OneHostGraph_NothingCrosses) {
  const Loaded l = load(kPolicy, replaced(replaced(replaced(replaced(kGraph, "  host: \"companion\"\n", ""),
                                                            "  host: \"companion\"\n", ""),
                                                   "hosts { name: \"vehicle\" address: \"10.77.0.1\" }\n", ""),
                                          "hosts { name: \"companion\" address: \"10.77.0.2\" }\n", ""));
  const auto t = host_topics(l.policy, placement(l.policy, l.graph), DdsNaming::Rejuv);
  ASSERT_EQ(t.size(), 1U);
  EXPECT_TRUE(t[0].publish.empty() && t[0].subscribe.empty());
}

// ---- the launch loader ----

LoadError load_error(const std::string& graph_text) {
  auto g = launch::parse_launch(graph_text, kDir / "companion.launch.pbtxt");
  EXPECT_FALSE(g.has_value());
  REJUV_ASSERT(!g.has_value(), "the graph must be refused");
  return g.error();
}

TEST(HostsLaunch, ServiceOnUndeclaredHost_RefusedWithSuggestion) {
  const std::string graph = replaced(kGraph, "  executable: \"o\"\n  host: \"companion\"", "  executable: \"o\"\n  host: \"companoin\"");
  const LoadError e = load_error(graph);
  EXPECT_EQ(e.where.line, line_of(graph, "host: \"companoin\""));
  EXPECT_NE(e.message.find("service \"monitor\" names host \"companoin\", which is not in the graph's `hosts` "
                           "(did you mean \"companion\"?)"),
            std::string::npos)
      << e.to_string();
}

TEST(HostsLaunch, HostWithoutHosts_Refused) {
  const std::string graph = replaced(replaced(kGraph, "hosts { name: \"vehicle\" address: \"10.77.0.1\" }\n", ""),
                                     "hosts { name: \"companion\" address: \"10.77.0.2\" }\n", "");
  const LoadError e = load_error(graph);
  EXPECT_NE(e.message.find("names host \"companion\", but the graph declares no `hosts"), std::string::npos)
      << e.to_string();
}

TEST(HostsLaunch, BadAddress_Refused) {
  const std::string graph = replaced(kGraph, "address: \"10.77.0.2\"", "address: \"10.77.0.300\"");
  const LoadError e = load_error(graph);
  EXPECT_EQ(e.where.line, line_of(graph, "10.77.0.300"));
  EXPECT_NE(e.message.find("host \"companion\": `address` must be an IPv4 address"), std::string::npos) << e.to_string();
}

TEST(HostsLaunch, DuplicateHost_Refused) {
  const std::string graph = replaced(kGraph, "name: \"companion\" address", "name: \"vehicle\" address");
  const LoadError e = load_error(graph);
  EXPECT_NE(e.message.find("duplicate host \"vehicle\""), std::string::npos) << e.to_string();
}

TEST(HostsLaunch, HostNameNotACommonName_Refused) {
  const std::string graph = replaced(kGraph, "name: \"companion\" address", "name: \"comp/anion\" address");
  const LoadError e = load_error(graph);
  EXPECT_NE(e.message.find("host name \"comp/anion\" must be 1…64 letters"), std::string::npos) << e.to_string();
}

}  // namespace
}  // namespace rejuv::policy
