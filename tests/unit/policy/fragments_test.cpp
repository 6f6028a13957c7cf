// Graph fragments (idl/launch.proto `include`, `policy_include`, `service_path`; docs/writing_a_service.md
// "Graph fragments"): a service brings its launch entry and its grants in two small files, a graph includes
// the project's hover and the fragment, and every finding is reported at the fragment's own file:line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::policy {
namespace {

const std::filesystem::path kHover = std::filesystem::path(REJUV_SOURCE_DIR) / "launch" / "hover.launch.pbtxt";

constexpr std::string_view kPolicyFragment =
    "services { name: \"geo\" }\n"
    "objects { name: \"geo_status\" kind: TOPIC type: \"rejuv::msg::VehicleStateEstimate\" kernel: KERNEL_SUBSCRIBES }\n"
    "grants { service: \"geo\" object: \"vehicle_state\" rights: \"R\" modes: [MC, RB, SC, UPDATE, CP] }\n"
    "grants { service: \"geo\" object: \"geo_status\" rights: \"W\" modes: [MC, RB, SC, UPDATE, CP] }\n";

class Fragments : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("rejuv_fragments_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_ / "geo" / "build");
    write("geo/geo.policy.pbtxt", std::string(kPolicyFragment));
    write("geo/build/geo", "#!/bin/sh\n");  // the executable the graph's service_path finds
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  // The service's launch fragment, with `uses` lines as given.
  void fragment(const std::string& uses) const {
    write("geo/geo.launch.pbtxt", "policy_include: \"geo.policy.pbtxt\"\nservices {\n  name: \"geo\"\n"
                                  "  executable: \"geo\"\n" + uses + "}\n");
  }
  std::filesystem::path graph() const {
    return write("flight.launch.pbtxt", "include: \"" + kHover.string() + "\"\ninclude: \"geo/geo.launch.pbtxt\"\n"
                                        "service_path: \"geo/build\"\nname: \"geo\"\nsr { enabled: true }\n");
  }

  std::filesystem::path dir_;
};

TEST_F(Fragments, ComposedGraph_LoadsAuditsCleanAndFindsTheExecutable) {
  fragment("  uses { object: \"vehicle_state\" rights: \"R\" }\n  uses { object: \"geo_status\" rights: \"W\" }\n");
  const auto hover = launch::load_launch(kHover);
  ASSERT_TRUE(hover.has_value()) << hover.error().to_string();
  const auto g = launch::load_launch(graph());
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  EXPECT_EQ(g->graph.services_size(), hover->graph.services_size() + 1);
  EXPECT_EQ(g->graph.name(), "geo");
  EXPECT_TRUE(g->graph.sr().enabled()) << "the graph's own field overrides the included hover's";
  EXPECT_DOUBLE_EQ(g->graph.sr().t_mc_s(), hover->graph.sr().t_mc_s()) << "the rest of hover's sr is kept";
  EXPECT_TRUE(std::filesystem::equivalent(g->policy_path, hover->policy_path))
      << "hover's relative policy path still means hover's policy: " << g->policy_path;
  const proto::ServiceSpec* geo = launch::find_service(g->graph, "geo");
  ASSERT_NE(geo, nullptr);
  EXPECT_EQ(geo->executable(), std::filesystem::absolute(dir_ / "geo" / "build" / "geo").lexically_normal().string());
  EXPECT_EQ(launch::find_service(g->graph, "sensors")->executable(), "rejuv_sensors")
      << "a name not in service_path stays for the kernel's service folder";
  ASSERT_EQ(g->policy_includes.size(), 1U);

  const auto p = load_policy(g->policy_path, g->policy_includes);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_TRUE(p->find_service("geo").has_value());
  const auto findings = audit(*p, *g);
  std::string all;
  for (const Finding& f : findings) all += f.to_string() + "\n";
  EXPECT_TRUE(findings.empty()) << all;
}

TEST_F(Fragments, UngrantedUse_FoundAtTheFragmentsLine) {
  fragment("  uses { object: \"vehicle_state\" rights: \"R\" }\n  uses { object: \"setpoint\" rights: \"R\" }\n");
  const auto g = launch::load_launch(graph());
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto p = load_policy(g->policy_path, g->policy_includes);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const auto findings = audit(*p, *g);
  ASSERT_FALSE(findings.empty());
  const std::string where = (dir_ / "geo" / "geo.launch.pbtxt").string() + ":6:";
  bool found = false;
  for (const Finding& f : findings) found = found || f.to_string().starts_with(where);
  EXPECT_TRUE(found) << "expected a finding at " << where << " (the fragment's `uses` of setpoint), got "
                     << findings.front().to_string();
}

TEST_F(Fragments, BadPolicyFragment_RefusedAtItsOwnLine) {
  fragment("  uses { object: \"vehicle_state\" rights: \"R\" }\n");
  write("geo/geo.policy.pbtxt", std::string(kPolicyFragment) +
                                    "grants { service: \"geo\" object: \"no_such_topic\" rights: \"R\" modes: MC }\n");
  const auto g = launch::load_launch(graph());
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto p = load_policy(g->policy_path, g->policy_includes);
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().where.file, (dir_ / "geo" / "geo.policy.pbtxt").string()) << p.error().to_string();
  EXPECT_EQ(p.error().where.line, 5) << p.error().to_string();
}

TEST_F(Fragments, MissingPolicyFragment_RefusedWhereTheLaunchFragmentNamesIt) {
  write("geo/geo.launch.pbtxt", "\npolicy_include: \"nope.policy.pbtxt\"\nservices { name: \"geo\" executable: \"geo\" }\n");
  const auto g = launch::load_launch(graph());
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto p = load_policy(g->policy_path, g->policy_includes);
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().where.to_string(), (dir_ / "geo" / "geo.launch.pbtxt").string() + ":2:1");
  EXPECT_NE(p.error().message.find("nope.policy.pbtxt"), std::string::npos) << p.error().message;
}

TEST_F(Fragments, LaunchErrorInAFragment_ReportedAgainstTheFragment) {
  write("geo/geo.launch.pbtxt", "services {\n  name: \"geo\"\n}\n");  // no executable
  const auto g = launch::load_launch(graph());
  ASSERT_FALSE(g.has_value());
  EXPECT_EQ(g.error().where.file, (dir_ / "geo" / "geo.launch.pbtxt").string()) << g.error().to_string();
}

}  // namespace
}  // namespace rejuv::policy
