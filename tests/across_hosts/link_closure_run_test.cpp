// The kernel closes the vehicle's link in the secure interval (kernel_sim/kernel link_guard.hpp; docs/across_hosts.md
// "Closing the link"): `rejuv run` flies the square with hosts whose uplinks are in network namespaces of this
// test (joined by a veth pair), and every close and open the kernel logs is checked against the mode trace it
// writes (events.csv): a close at each MC → secure mode, an open at each return to MC, in that order, none
// else; the table exists during the run and is gone after it. That a closed link carries nothing is
// sys::LinkClosure's test (tests/unit/sys/link_closure_test.cpp). Root only; skipped otherwise.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "../netns_pair.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"

namespace {

namespace fs = std::filesystem;
using rejuv::test_support::CliOutcome;
using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;

const fs::path kIp = "/usr/sbin/ip";

class LinkClosureRun : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: network namespaces, a veth pair and nftables";
    dir_ = fs::temp_directory_path() / ("rejuv_link_closure_run_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "cmd");
    hosts_.emplace(dir_ / "cmd", "rjN_r");
    const std::string error = hosts_->make("", "");
    ASSERT_TRUE(error.empty()) << error;
  }
  void TearDown() override {
    hosts_.reset();  // before its folder goes
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }

  // The square with two hosts, every service on the vehicle's; the vehicle's uplink in its namespace.
  fs::path graph() const {
    const fs::path g = dir_ / "square_hosts.launch.pbtxt";
    std::ofstream(g) << "include: \"" << (kRepo / "launch" / "quad_square.launch.pbtxt").string() << "\"\n"
                     << "name: \"square_hosts\"\n"
                     << "hosts { name: \"vehicle\" address: \"10.78.0.1\" netns: \"" << hosts_->vehicle << "\" }\n"
                     << "hosts { name: \"companion\" address: \"10.78.0.2\" netns: \"" << hosts_->companion << "\" }\n";
    return g;
  }

  fs::path dir_;
  std::optional<rejuv::test_support::NetnsPair> hosts_;
};

// The kernel's link lines, as "closed MC → RB" / "opened CP → MC" (the start's close as "closed start SC").
std::vector<std::string> link_changes(const std::string& log) {
  std::vector<std::string> out;
  static const std::regex line(R"(link vehicle (closed|opened) at (?:(\w+) → (\w+)|the start in (\w+)) \()");
  std::istringstream in(log);
  for (std::string l; std::getline(in, l);) {
    std::smatch m;
    if (!std::regex_search(l, m, line)) continue;
    out.push_back(m[4].matched ? m[1].str() + " start " + m[4].str()
                               : m[1].str() + " " + m[2].str() + " → " + m[3].str());
  }
  return out;
}

// What the mode trace (events.csv: t_s,wall_s,kind,epoch,generation,mode,…) says the links must do: closed at
// the start if it starts in the secure interval, at each MC → other; opened at each other → MC.
std::vector<std::string> expected_changes(const std::string& events) {
  std::vector<std::string> out;
  std::istringstream in(events);
  std::string line, previous;
  std::getline(in, line);  // header
  auto name = [](const std::string& m) { return m == "UP" ? std::string("UPDATE") : m; };
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() < 6 || f[2] != "mode") continue;
    const std::string mode = name(f[5]);
    if (previous.empty()) {
      if (mode != "MC") out.push_back("closed start " + mode);
    } else if (previous == "MC" && mode != "MC") {
      out.push_back("closed MC → " + mode);
    } else if (previous != "MC" && mode == "MC") {
      out.push_back("opened " + previous + " → MC");
    }
    previous = mode;
  }
  return out;
}

TEST_F(LinkClosureRun, EveryCloseAndOpen_MatchesTheModeTrace) {
  const fs::path out = dir_ / "out";
  fs::create_directories(dir_ / "run");
  const pid_t run = rejuv::test_support::start_program(
      dir_ / "run", rejuv::test_support::kRejuv,
      {"run", graph().string(), "--duration", "3", "--out", out.string(), "--no-figures"});
  ASSERT_GT(run, 0);
  // While it runs (the first lines name the closure), the table is in the vehicle's namespace.
  std::string tables;
  for (int i = 0; i < 2000 && slurp(dir_ / "run" / "stderr").find("link vehicle closed") == std::string::npos; ++i) {
    ::usleep(5'000);
  }
  tables = rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "exec", hosts_->vehicle, "nft", "list", "tables"}).out;
  const CliOutcome r = rejuv::test_support::wait_program(dir_ / "run", run);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(tables.find("rejuv_link_vehicle"), std::string::npos) << tables;
  EXPECT_NE(r.err.find("link vehicle: closed in the secure interval by nftables table netdev rejuv_link_vehicle in netns " +
                       hosts_->vehicle),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("link companion"), std::string::npos) << "the companion runs no service here:\n" << r.err;

  const std::vector<std::string> got = link_changes(r.err);
  const std::vector<std::string> want = expected_changes(slurp(out / "events.csv"));
  ASSERT_GE(want.size(), 4U) << "the 3-s flight changed mode too rarely to check:\n" << slurp(out / "events.csv");
  // The run stops at --duration: a mode change after the last the log shows is not in either.
  EXPECT_EQ(got, want) << r.err;

  const std::string after =
      rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "exec", hosts_->vehicle, "nft", "list", "tables"}).out;
  EXPECT_EQ(after.find("rejuv_link_vehicle"), std::string::npos) << after;
}

// A host whose uplink is in the kernel's own namespace (hosts.netns unset: a real computer whose interface carries
// the link) has no table — one over every interface would cut the ground station and the shell too — and its
// link services are frozen in the secure interval instead (cgroup.freeze). The vehicle's part of a graph with a
// monitor on the companion, both hosts on this namespace's loopback: the kernel says how the link is closed, and
// its link service's closes and opens follow the mode trace from the first MC → RB (frozen through the start in
// SC and the 20 s alignment, it would not read its channel, and the kernel would kill it). The link boots at all only because it keeps the
// kernel's network namespace (an empty one has no interface for its Cyclone participant). That a frozen cgroup runs nothing is sys::LinkClosure's test.
TEST_F(LinkClosureRun, NoNetns_LinkServiceFrozen_EveryCloseAndOpenMatchesTheModeTrace) {
  const fs::path g = dir_ / "square_own_ns.launch.pbtxt";
  std::ofstream(g) << "include: \"" << (kRepo / "launch" / "quad_square.launch.pbtxt").string() << "\"\n"
                   << "name: \"square_own_ns\"\n"
                   << "policy_include: \"" << (kRepo / "tests" / "across_hosts" / "monitor.policy.pbtxt").string()
                   << "\"\n"
                   << "hosts { name: \"vehicle\" address: \"127.0.0.1\" }\n"
                   << "hosts { name: \"companion\" address: \"127.0.0.2\" }\n"
                   << "services { name: \"monitor\" executable: \"" << REJUV_ACROSS_MONITOR << "\" host: \"companion\"\n"
                   << "  uses { object: \"vehicle_state\" rights: \"R\" } }\n";
  const fs::path keys = dir_ / "keys";
  const std::string domain = std::to_string(rejuv::test_support::kOwnDdsDomain);
  for (const std::vector<std::string>& cmd : {std::vector<std::string>{"keys", "init", keys.string()},
                                              {"keys", "hosts", keys.string(), "--launch", g.string(), "--domain", domain}}) {
    const CliOutcome made = rejuv::test_support::run_rejuv(dir_ / "cmd", cmd);
    ASSERT_EQ(made.exit_code, 0) << "rejuv keys " << cmd[1] << ": " << made.err;
  }
  const fs::path out = dir_ / "own_ns_out";
  fs::create_directories(dir_ / "own_ns");
  const CliOutcome r = rejuv::test_support::run_rejuv(
      dir_ / "own_ns", {"run", g.string(), "--host", "vehicle", "--keys", keys.string(), "--domain", domain,
                        "--duration", "3", "--no-attack", "--net-port", "0", "--out", out.string(), "--no-figures"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("link vehicle: its uplink is in the kernel's own network namespace (hosts.netns unset), whose "
                       "every interface a table would close; closed in the secure interval by freezing "
                       "link_companion's cgroup (cgroup.freeze, v2) instead, from the first MC → RB"),
            std::string::npos)
      << r.err;
  const std::vector<std::string> got = link_changes(r.err);
  std::vector<std::string> want = expected_changes(slurp(out / "events.csv"));
  // Frozen from the first MC → RB: the trace's close at the start and the open of the first MC are not the link's.
  ASSERT_GE(want.size(), 2U) << slurp(out / "events.csv");
  ASSERT_TRUE(want[0].starts_with("closed start ") && want[1].starts_with("opened ")) << want[0] << ", " << want[1];
  want.erase(want.begin(), want.begin() + 2);
  ASSERT_GE(want.size(), 4U) << "the 3-s flight changed mode too rarely to check:\n" << slurp(out / "events.csv");
  EXPECT_EQ(got, want) << r.err;
}

TEST_F(LinkClosureRun, NoSr_NoClosure) {
  fs::create_directories(dir_ / "nosr");
  const CliOutcome r = rejuv::test_support::run_rejuv(dir_ / "nosr", {"run", graph().string(), "--duration", "1", "--no-sr", "--no-attack"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("link vehicle"), std::string::npos) << "without SR the mode never leaves MC:\n" << r.err;
}

}  // namespace
