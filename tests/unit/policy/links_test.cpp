// The link between hosts (policy/hosts.hpp "The link", docs/across_hosts.md): each host's link services are
// exactly its crossings in MC, per peer; add_host_links makes them a policy fragment the policy loads with the
// rest and ServiceSpecs of the graph; compiled, the link holds its caps in MC and nothing in the secure interval;
// the audit stays clean on a graph whose crossings are MC-only. Fixture: tests/across_hosts/companion.*.pbtxt
// (`state` crosses vehicle → companion, `waypoints` companion → vehicle, both MC-only).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/hosts.hpp"
#include "rejuv/policy/policy.hpp"
#include "companion_files.hpp"
#include "../../rejuv_cli.hpp"

namespace rejuv::policy {
namespace {

using companion::all;
using companion::read;
using companion::replaced;
const std::filesystem::path& kDir = companion::kCompanionDir;

const std::string kGraph = read(kDir / "companion.launch.pbtxt");

launch::LoadedLaunch graph_of(const std::string& text) {
  auto g = launch::parse_launch(text, kDir / "companion.launch.pbtxt");
  EXPECT_TRUE(g.has_value()) << g.error().to_string();
  REJUV_ASSERT(g.has_value(), "test graph must load");
  return std::move(*g);
}

// Each test writes the links' fragment into a folder of its own (per test and process: ctest runs this file's
// tests side by side), removed when the test ends.
class HostLinks : public test_support::ScratchDirTest {
 protected:
  HostLinks() : ScratchDirTest("links_test_") {}
  [[nodiscard]] std::filesystem::path fresh_dir(std::string_view name) const {
    std::filesystem::create_directories(dir_ / name);
    return dir_ / name;
  }
};

std::vector<std::string> names(const Policy& p, const std::vector<ObjectId>& ids) {
  std::vector<std::string> out;
  for (const ObjectId id : ids) out.push_back(p.object(id).name);
  return out;
}

TEST_F(HostLinks, EachHostLinksItsPeerWithExactlyTheMcCrossings) {
  const launch::LoadedLaunch g = graph_of(kGraph);
  auto p = load_policy(g.policy_path, g.policy_includes);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const Placement place = placement(*p, g);
  const auto vehicle = host_links(*p, place, 0);
  ASSERT_EQ(vehicle.size(), 1U);
  EXPECT_EQ(vehicle[0].peer, 1U);
  EXPECT_EQ(names(*p, vehicle[0].writes), std::vector<std::string>{"waypoints"});  // the planner's, for commander
  EXPECT_EQ(names(*p, vehicle[0].reads), std::vector<std::string>{"state"});       // est's, for the monitor
  const auto companion = host_links(*p, place, 1);
  ASSERT_EQ(companion.size(), 1U);
  EXPECT_EQ(companion[0].peer, 0U);
  EXPECT_EQ(names(*p, companion[0].writes), std::vector<std::string>{"state"});
  EXPECT_EQ(names(*p, companion[0].reads), std::vector<std::string>{"waypoints"});
}

TEST_F(HostLinks, CrossingOnlyInTheSecureInterval_CarriesNothing) {
  // The monitor reads `state` only in SC: the pair never meets in MC, so no link carries it (the audit's
  // `hosts:mc-only` names the grant).
  const std::string policy_text = replaced(read(kDir / "companion.policy.pbtxt"),
                                           "grants { service: \"monitor\" object: \"state\" rights: \"R\" modes: [MC] }",
                                           "grants { service: \"monitor\" object: \"state\" rights: \"R\" modes: [SC] }");
  auto p = parse_policy(policy_text, (kDir / "companion.policy.pbtxt").string());
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const launch::LoadedLaunch g = graph_of(kGraph);
  const auto vehicle = host_links(*p, placement(*p, g), 0);
  ASSERT_EQ(vehicle.size(), 1U);
  EXPECT_TRUE(vehicle[0].reads.empty());
  EXPECT_EQ(names(*p, vehicle[0].writes), std::vector<std::string>{"waypoints"});
}

// The graph of host `host`'s kernel with its links, loaded as the kernel loads it.
struct WithLinks {
  launch::LoadedLaunch graph;
  AddedLinks added;
  Policy policy;
};
WithLinks with_links(std::string_view host, const std::filesystem::path& dir) {
  launch::LoadedLaunch g = graph_of(kGraph);
  auto added = add_host_links(g, host, dir);
  EXPECT_TRUE(added.has_value()) << added.error();
  REJUV_ASSERT(added.has_value(), "the links must be added");
  auto p = load_policy(g.policy_path, g.policy_includes);
  EXPECT_TRUE(p.has_value()) << p.error().to_string();
  REJUV_ASSERT(p.has_value(), "the policy with the links must load");
  return WithLinks{std::move(g), std::move(*added), std::move(*p)};
}

TEST_F(HostLinks, AddedToGraphAndPolicy_DriverNetworkFacingMcOnly) {
  const WithLinks w = with_links("vehicle", fresh_dir("vehicle"));
  ASSERT_EQ(w.added.links.size(), 1U);
  EXPECT_TRUE(std::filesystem::is_regular_file(w.added.fragment));
  // The launch view: rejuv_host_link on the vehicle's host, never rolled back, using what it is granted.
  const proto::ServiceSpec* spec = launch::find_service(w.graph.graph, "link_companion");
  ASSERT_NE(spec, nullptr);
  EXPECT_EQ(spec->executable(), "rejuv_host_link");
  EXPECT_EQ(spec->host(), "vehicle");
  EXPECT_FALSE(launch::rejuvenate(*spec));
  EXPECT_TRUE(is_host_link(w.graph.graph, *spec));
  ASSERT_EQ(spec->uses_size(), 2);
  EXPECT_EQ(spec->uses(0).object() + spec->uses(0).rights(), "waypointsW");
  EXPECT_EQ(spec->uses(1).object() + spec->uses(1).rights(), "stateR");
  // The policy: a network-facing driver with its two grants, MC only.
  const auto id = w.policy.find_service("link_companion");
  ASSERT_TRUE(id.has_value());
  EXPECT_EQ(w.policy.service(*id).level, ServiceLevel::Driver);
  EXPECT_TRUE(w.policy.is_network_facing(*id));
  const ObjectId state = *w.policy.find_object("state");
  const ObjectId waypoints = *w.policy.find_object("waypoints");
  EXPECT_EQ(w.policy.rights(*id, state, SrMode::MC).letters(), "R");
  EXPECT_EQ(w.policy.rights(*id, waypoints, SrMode::MC).letters(), "W");
  // Compiled for the kernel: its slots hold those rights in MC and nothing in any mode of the secure interval.
  const cap::ModeTable table = compile(w.policy);
  int slots = 0;
  for (const cap::SlotGrant& s : table.slots) {
    if (s.service != *id) continue;
    ++slots;
    EXPECT_FALSE(s.rights[index_of(SrMode::MC)].empty()) << table.objects[s.object.value()].name;
    for (const SrMode m : {SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP}) {
      EXPECT_TRUE(s.rights[index_of(m)].empty()) << table.objects[s.object.value()].name << " in " << to_string(m);
    }
  }
  EXPECT_EQ(slots, 2);
}

TEST_F(HostLinks, AuditClean_OnEitherHost) {
  for (const std::string_view host : {"vehicle", "companion"}) {
    const WithLinks w = with_links(host, fresh_dir(host));
    const auto f = audit(w.policy, w.graph);
    EXPECT_TRUE(f.empty()) << host << ":\n" << all(f);
    const std::string peer = host == "vehicle" ? "companion" : "vehicle";
    EXPECT_NE(launch::find_service(w.graph.graph, link_service_name(peer)), nullptr) << host;
  }
}

TEST_F(HostLinks, LinkGrantInTheSecureInterval_RefusedByTheAudit) {
  // A link is audited as any service: one that would carry `state` in SC too crosses in the secure interval.
  WithLinks w = with_links("companion", fresh_dir("companion_sei"));
  std::string text = read(w.added.fragment);
  std::ofstream(w.added.fragment, std::ios::trunc)
      << replaced(text, "object: \"state\" rights: \"W\" modes: MC", "object: \"state\" rights: \"W\" modes: [MC, SC]");
  auto p = load_policy(w.graph.policy_path, w.graph.policy_includes);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const auto f = audit(*p, w.graph);
  EXPECT_NE(all(f).find("hosts:mc-only"), std::string::npos) << all(f);
  EXPECT_NE(all(f).find("link_vehicle"), std::string::npos) << all(f);
}

TEST_F(HostLinks, UnknownHost_Refused) {
  launch::LoadedLaunch g = graph_of(kGraph);
  auto added = add_host_links(g, "companoin", fresh_dir("unknown"));
  ASSERT_FALSE(added.has_value());
  EXPECT_NE(added.error().find("no host 'companoin'"), std::string::npos) << added.error();
}

TEST_F(HostLinks, NothingCrossing_NoLink) {
  // Without the planner's and the monitor's MC grants nothing crosses: no link, no fragment.
  std::string text = kGraph;
  text = replaced(text, "  host: \"companion\"\n", "");
  text = replaced(text, "  host: \"companion\"\n", "");
  launch::LoadedLaunch g = graph_of(text);
  const int before = g.graph.services_size();
  auto added = add_host_links(g, "vehicle", fresh_dir("none"));
  ASSERT_TRUE(added.has_value()) << added.error();
  EXPECT_TRUE(added->links.empty());
  EXPECT_TRUE(added->fragment.empty());
  EXPECT_EQ(g.graph.services_size(), before);
}

}  // namespace
}  // namespace rejuv::policy
