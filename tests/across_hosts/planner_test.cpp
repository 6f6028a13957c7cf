// The companion's waypoints are flown, and nothing it writes in the vehicle's secure interval reaches the vehicle
// (docs/across_hosts.md "The companion's mission"; root only, skipped otherwise). The set-up of link_fixture.hpp
// (two namespaces joined by a veth pair, rjQ_v<pid> and rjQ_c<pid>; the square with SR on the vehicle, the
// monitor on the companion) with the planner of planner.cpp added on the companion: it writes a one-waypoint
// mission on mission_upload every 50 ms, each sample stamped with its write time (CLOCK_MONOTONIC, the clock of
// the vehicle's events.csv `wall_s`), and logs the stamps. Checked, from the runs' outputs:
//   - the vehicle's true position (its trace.csv) comes within 0.15 m of the planner's waypoint, which is
//     0.5 m off the graph's own square in both north and east;
//   - every mission_upload the vehicle's kernel routed (the ULog of --ulog-profile full: a D message per routed
//     message, read by @foxglove/ulog) is a sample the planner wrote while the vehicle was in MC (its mode trace
//     in events.csv), and none the planner wrote while the vehicle was in RB, SC, UPDATE or CP is among them —
//     with at least one of each kind written, so that the check has something to refuse.
// No timing is asserted: the runs last as long as they last.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "../node_script.hpp"
#include "link_fixture.hpp"

namespace {

using namespace rejuv::test_support::across;

const fs::path kPlanner = REJUV_ACROSS_PLANNER;
const fs::path kReaderModules = fs::path(REJUV_BINARY_DIR) / "ulog_reader" / "node_modules";

// The vehicle's modes from its events.csv: wall_s [s, CLOCK_MONOTONIC] → the mode entered then (MC, RB, SC, UP, CP).
using ModeTrace = std::map<double, std::string>;

ModeTrace mode_trace(const fs::path& events) {
  ModeTrace out;
  std::istringstream lines(slurp(events));
  std::string line;
  std::getline(lines, line);  // t_s,wall_s,kind,epoch,generation,mode,span_ms,by
  while (std::getline(lines, line)) {
    std::vector<std::string> f;
    std::stringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() >= 6 && f[2] == "mode") out[std::stod(f[1])] = f[5];
  }
  return out;
}

// The vehicle's mode at monotonic time `ns`: that of the last change at or before it; before the first, SC (the
// kernel starts in SC, its link closed).
std::string mode_at(const ModeTrace& trace, std::uint64_t ns) {
  const double t = static_cast<double>(ns) / 1e9;
  auto it = trace.upper_bound(t);
  if (it == trace.begin()) return "SC";
  return std::prev(it)->second;
}

// Every stamp the planner logged ("… stamps [monotonic ns]: s1 s2 …").
std::vector<std::uint64_t> planner_stamps(const std::string& log) {
  static const std::regex line(R"(stamps \[monotonic ns\]:([ 0-9]*))");
  std::vector<std::uint64_t> out;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), line); it != std::sregex_iterator(); ++it) {
    std::istringstream words((*it)[1].str());
    for (std::uint64_t s = 0; words >> s;) out.push_back(s);
  }
  return out;
}

// The closest the vehicle's true position (trace.csv n_m, e_m, d_m) came to `wp` [m]; +inf without a row.
double closest_approach(const fs::path& trace, const std::array<double, 3>& wp) {
  std::istringstream lines(slurp(trace));
  std::string line;
  std::getline(lines, line);  // t_s,n_m,e_m,d_m,…
  double best = INFINITY;
  while (std::getline(lines, line)) {
    std::array<double, 3> p{};
    std::stringstream cells(line);
    std::string c;
    std::getline(cells, c, ',');  // t_s
    for (double& v : p) {
      if (!std::getline(cells, c, ',')) return best;
      v = std::stod(c);
    }
    best = std::min(best, std::hypot(p[0] - wp[0], p[1] - wp[1], p[2] - wp[2]));
  }
  return best;
}

class PlannerLink : public TwoHostsTest {
 protected:
  PlannerLink() : TwoHostsTest("rjQ") {}

  // The planner on the companion (the keystore's permissions then grant rejuv/mission_upload: the companion
  // publishes it, the vehicle subscribes to it).
  [[nodiscard]] std::string more_graph() const override {
    return "policy_include: \"" + (kRepo / "tests" / "across_hosts" / "planner.policy.pbtxt").string() + "\"\n" +
           "services { name: \"planner\" executable: \"" + kPlanner.string() + "\" host: \"companion\"\n" +
           "  uses { object: \"mission_upload\" rights: \"W\" } }\n";
  }

  // The vehicle's run with its outputs (trace.csv, events.csv, run.ulg of every routed message) in dir/vehicle/out.
  std::unique_ptr<KernelRun> start_vehicle(int seconds) {
    return start("vehicle", seconds, false,
                 {"--out", (dir_ / "vehicle" / "out").string(), "--no-figures", "--ulog-profile", "full"});
  }

  // The timestamp_ns of every mission_upload in the vehicle's ULog (routed_uploads.js).
  std::vector<std::uint64_t> routed_uploads() {
    const fs::path out = dir_ / "routed.txt";
    const pid_t pid = rejuv::test_support::start_node_script(kRepo / "tests/across_hosts/routed_uploads.js", kReaderModules,
                                                             {(dir_ / "vehicle" / "out" / "run.ulg").string()}, out);
    int status = 0;
    EXPECT_TRUE(pid > 0 && ::waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "node routed_uploads.js failed (is @foxglove/ulog installed in " << kReaderModules << "?)";
    std::vector<std::uint64_t> stamps;
    std::istringstream words(slurp(out));
    for (std::uint64_t s = 0; words >> s;) stamps.push_back(s);
    return stamps;
  }
};

TEST_F(PlannerLink, CompanionWaypointFlown_NothingWrittenInTheSecureIntervalRouted) {
  ASSERT_TRUE(fs::exists(kReaderModules / "@foxglove/ulog/package.json")) << "./rejuv installs @foxglove/ulog";
  // The companion outlasts the vehicle; the vehicle flies long enough to reach the waypoint (0.7 m from home).
  auto companion = start("companion", 70);
  ASSERT_GT(companion->pid(), 0);
  auto vehicle = start_vehicle(45);
  ASSERT_GT(vehicle->pid(), 0);
  const CliOutcome v = vehicle->wait();
  ASSERT_EQ(v.exit_code, 0) << v.out << v.err;
  ASSERT_EQ(::kill(companion->pid(), SIGINT), 0);
  const CliOutcome c = companion->wait();

  // The planner's waypoint, as it logged it; the vehicle flew there.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(c.err, m, std::regex(R"(\(waypoint (\S+) (\S+) (\S+) m\))"))) << c.err;
  const std::array<double, 3> wp{std::stod(m[1].str()), std::stod(m[2].str()), std::stod(m[3].str())};
  EXPECT_NE(v.err.find("[gen_set_point] flying the uploaded mission of 1 waypoints"), std::string::npos) << v.err;
  EXPECT_LT(closest_approach(dir_ / "vehicle" / "out" / "trace.csv", wp), 0.15)
      << "the vehicle did not reach the planner's waypoint " << wp[0] << " " << wp[1] << " " << wp[2];

  // What the planner wrote, by the vehicle's mode when it wrote it; what the vehicle's kernel routed.
  const ModeTrace trace = mode_trace(dir_ / "vehicle" / "out" / "events.csv");
  ASSERT_FALSE(trace.empty());
  const std::vector<std::uint64_t> written = planner_stamps(c.err);
  std::set<std::uint64_t> written_in_mc, written_secure;
  for (const std::uint64_t s : written) (mode_at(trace, s) == "MC" ? written_in_mc : written_secure).insert(s);
  EXPECT_FALSE(written_in_mc.empty());
  EXPECT_FALSE(written_secure.empty());
  const std::vector<std::uint64_t> routed = routed_uploads();
  ASSERT_FALSE(routed.empty()) << "no mission_upload routed on the vehicle";
  std::size_t from_planner = 0;
  for (const std::uint64_t s : routed) {
    EXPECT_EQ(written_secure.count(s), 0U) << "a sample the planner wrote at " << s << " ns, in the vehicle's "
                                           << mode_at(trace, s) << ", was routed on the vehicle";
    EXPECT_EQ(mode_at(trace, s), "MC") << "routed: a mission_upload stamped " << s << " ns";
    from_planner += written_in_mc.count(s);
  }
  EXPECT_GT(from_planner, 0U);
  std::printf("planner: %zu samples written in the vehicle's MC, %zu in its secure interval; %zu routed on the "
              "vehicle, %zu of them the planner's; closest approach %.3f m\n",
              written_in_mc.size(), written_secure.size(), routed.size(), from_planner,
              closest_approach(dir_ / "vehicle" / "out" / "trace.csv", wp));
}

}  // namespace
