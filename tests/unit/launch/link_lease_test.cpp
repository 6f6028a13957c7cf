// The loader's check that a link closed in the secure interval does not outlast the DDS lease (kernel_sim/launch
// hosts.cpp check_link_lease; docs/across_hosts.md "Closing the link"): the square with two hosts, the vehicle's
// uplink in a network namespace, loads with Cyclone's default lease (10 s) against T_est 0.05 s; T_est 10 s is
// refused at its line, naming both numbers; a config's <LeaseDuration> of 30 s admits it again, one of 500 ms
// refuses T_est 1 s naming the config; a lease that is not a duration is refused. A graph without a host in a
// namespace is not checked.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "rejuv/launch/launch.hpp"

namespace {

namespace fs = std::filesystem;
const fs::path kRepo(REJUV_SOURCE_DIR);

class LinkLease : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rejuv_link_lease_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  // The square with two hosts (the vehicle's in a namespace unless `netns` is empty) and `extra` lines.
  rejuv::Result<rejuv::launch::LoadedLaunch, rejuv::LoadError> load(const std::string& extra,
                                                                     const std::string& netns = "rjN_lease") {
    const fs::path g = dir_ / "g.launch.pbtxt";
    std::ofstream(g) << "include: \"" << (kRepo / "launch" / "quad_square.launch.pbtxt").string() << "\"\n"
                     << "name: \"square_hosts\"\n"
                     << "hosts { name: \"vehicle\" address: \"10.78.0.1\" netns: \"" << netns << "\" }\n"
                     << "hosts { name: \"companion\" address: \"10.78.0.2\" }\n"
                     << extra;
    return rejuv::launch::load_launch(g);
  }
  // A Cyclone config beside the graph with `lease` as its Discovery/LeaseDuration.
  void config(const std::string& lease) {
    std::ofstream(dir_ / "dds.xml") << "<CycloneDDS><Domain id=\"any\"><Discovery><LeaseDuration>" << lease
                                    << "</LeaseDuration></Discovery></Domain></CycloneDDS>\n";
  }
  fs::path dir_;
};

TEST_F(LinkLease, DefaultLeaseOutlastsTheSquaresInterval_Loads) {
  auto g = load("");
  EXPECT_TRUE(g) << g.error().to_string();
}

TEST_F(LinkLease, SecureIntervalLongerThanDefaultLease_RefusedAtTEst) {
  auto g = load("sr { t_est_s: 10 }\n");
  ASSERT_FALSE(g);
  const std::string m = g.error().to_string();
  EXPECT_NE(m.find("g.launch.pbtxt:5:"), std::string::npos) << m;  // the sr block's t_est_s
  EXPECT_NE(m.find("at least T_est 10 s + t_min 0.02 s = 10.02 s"), std::string::npos) << m;
  EXPECT_NE(m.find("the DDS lease (Cyclone's default) is 10 s"), std::string::npos) << m;
}

TEST_F(LinkLease, ConfigLeaseLongerThanTheInterval_Loads) {
  config("30 s");
  auto g = load("sr { t_est_s: 10 }\ndds { config: \"dds.xml\" }\n");
  EXPECT_TRUE(g) << g.error().to_string();
}

TEST_F(LinkLease, ConfigLeaseShorterThanTheInterval_RefusedNamingTheConfig) {
  config("500 ms");
  auto g = load("sr { t_est_s: 1 }\ndds { config: \"dds.xml\" }\n");
  ASSERT_FALSE(g);
  const std::string m = g.error().to_string();
  EXPECT_NE(m.find("<LeaseDuration> of " + (dir_ / "dds.xml").string() + ") is 0.5 s"), std::string::npos) << m;
}

TEST_F(LinkLease, ConfigLeaseNotADuration_Refused) {
  config("ten seconds");
  auto g = load("dds { config: \"dds.xml\" }\n");
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().to_string().find("<LeaseDuration>ten seconds</LeaseDuration> is not a duration"),
            std::string::npos)
      << g.error().to_string();
}

TEST_F(LinkLease, NoHostInANamespace_NotChecked) {
  auto g = load("sr { t_est_s: 10 }\n", "");
  EXPECT_TRUE(g) << g.error().to_string();
}

}  // namespace
