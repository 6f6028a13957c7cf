// The companion's waypoints are flown, and nothing it writes in the vehicle's secure interval reaches the vehicle
// (docs/across_hosts.md "The companion's mission"; root only, skipped otherwise). The set-up of link_fixture.hpp
// (two namespaces joined by a veth pair, rjQ_v<pid> and rjQ_c<pid>; the square with SR on the vehicle, the
// monitor on the companion) with the planner of planner.cpp added on the companion: it writes a one-waypoint
// mission on mission_upload every 50 ms, each sample stamped with its write time (CLOCK_MONOTONIC, the clock of
// the vehicle's events.csv `wall_s`), and logs the stamps. Checked, from the runs' outputs:
//   - the vehicle's true position (its trace.csv) comes within 0.15 m of the planner's waypoint, which is
//     0.5 m off the graph's own square in both north and east;
//   - every mission_upload the vehicle's kernel routed (the ULog of --ulog-profile full: a D message per routed
//     message, read by @foxglove/ulog) was routed in MC (its mode trace in events.csv, on the kernel clock);
//   - one the planner stamped while the vehicle was in RB, SC, UPDATE or CP was routed in the MC window right
//     after its stamp, never a later one: the stamp precedes the companion's routing and the DDS write, and the
//     vehicle's link admits only what was written after MC began — with samples stamped in both, so that the
//     check has something to refuse. That nothing crosses in the secure interval itself is shown on the wire
//     (HostLink.Square: every packet captured, against the secure intervals).
// No timing is asserted: the runs last as long as they last.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "../node_script.hpp"
#include "link_fixture.hpp"

namespace {

using namespace rejuv::test_support::across;

const fs::path kPlanner = REJUV_ACROSS_PLANNER;
const fs::path kReaderModules = fs::path(REJUV_BINARY_DIR) / "ulog_reader" / "node_modules";

// The vehicle's mode changes from its events.csv, in order: each at kernel time t_s and at wall_s
// [s, CLOCK_MONOTONIC], the mode entered then (MC, RB, SC, UP, CP).
struct ModeChange {
  double t_s = 0, wall_s = 0;
  std::string mode;
};
using ModeTrace = std::vector<ModeChange>;

ModeTrace mode_trace(const fs::path& events) {
  ModeTrace out;
  std::istringstream lines(slurp(events));
  std::string line;
  std::getline(lines, line);  // t_s,wall_s,kind,epoch,generation,mode,span_ms,by
  while (std::getline(lines, line)) {
    std::vector<std::string> f;
    std::stringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() >= 6 && f[2] == "mode") out.push_back({std::stod(f[0]), std::stod(f[1]), f[5]});
  }
  return out;
}

// The index of the last change at or before `t` on the wall clock; on the kernel clock the last one before it
// (both files round to the microsecond: a message routed in the microsecond before a change is routed before it,
// and none is routed in the microsecond after MC begins, the link not having polled yet). nullopt before the first
// (the kernel starts in SC, its link closed).
std::optional<std::size_t> change_at(const ModeTrace& trace, double t, bool wall) {
  std::optional<std::size_t> at;
  for (std::size_t i = 0; i < trace.size() && (wall ? trace[i].wall_s <= t : trace[i].t_s < t); ++i) at = i;
  return at;
}
std::string mode_at_wall(const ModeTrace& trace, std::uint64_t ns) {
  const auto i = change_at(trace, static_cast<double>(ns) / 1e9, true);
  return i ? trace[*i].mode : "SC";
}

// A mission_upload the vehicle's kernel routed: the planner's stamp [ns, CLOCK_MONOTONIC] and the flight time at
// which it was routed [us] (events.csv's t_s clock).
struct Routed {
  std::uint64_t stamp_ns = 0;
  std::int64_t routed_us = 0;  // negative: routed during the alignment
};

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

  // Every mission_upload in the vehicle's ULog: its timestamp_ns (the planner's stamp) and when the kernel routed
  // it, in flight time (routed_uploads.js).
  std::vector<Routed> routed_uploads() {
    const fs::path out = dir_ / "routed.txt";
    const pid_t pid = rejuv::test_support::start_node_script(kRepo / "tests/across_hosts/routed_uploads.js", kReaderModules,
                                                             {(dir_ / "vehicle" / "out" / "run.ulg").string()}, out);
    int status = 0;
    EXPECT_TRUE(pid > 0 && ::waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "node routed_uploads.js failed (is @foxglove/ulog installed in " << kReaderModules << "?)";
    std::vector<Routed> routed;
    std::istringstream words(slurp(out));
    for (Routed r; words >> r.stamp_ns >> r.routed_us;) routed.push_back(r);
    return routed;
  }
};

TEST_F(PlannerLink, CompanionWaypointFlown_RoutedOnlyInMc_NothingKeptAcrossASecureInterval) {
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

  // What the planner wrote, by the vehicle's mode when it stamped it; what the vehicle's kernel routed, and when.
  const ModeTrace trace = mode_trace(dir_ / "vehicle" / "out" / "events.csv");
  ASSERT_FALSE(trace.empty());
  const std::vector<std::uint64_t> written = planner_stamps(c.err);
  std::set<std::uint64_t> written_in_mc, written_secure;
  for (const std::uint64_t s : written) (mode_at_wall(trace, s) == "MC" ? written_in_mc : written_secure).insert(s);
  EXPECT_FALSE(written_in_mc.empty());
  EXPECT_FALSE(written_secure.empty());
  const std::vector<Routed> routed = routed_uploads();
  ASSERT_FALSE(routed.empty()) << "no mission_upload routed on the vehicle";
  std::size_t from_planner = 0, stamped_before_mc = 0;
  double lead_max_ms = 0;
  for (const Routed& r : routed) {
    // Routed by the vehicle's kernel only in MC (the link's Write is MC-only, checked at each publication).
    const auto window = change_at(trace, static_cast<double>(r.routed_us) / 1e6, false);
    ASSERT_TRUE(window.has_value()) << "a mission_upload routed before the first mode change, at " << r.routed_us << " us";
    EXPECT_EQ(trace[*window].mode, "MC") << "a mission_upload routed at " << r.routed_us << " us, in "
                                         << trace[*window].mode;
    from_planner += written_in_mc.count(r.stamp_ns) + written_secure.count(r.stamp_ns);
    if (written_secure.count(r.stamp_ns) == 0) continue;
    // Stamped in the secure interval: the planner stamps a sample before its kernel routes it to the link and
    // the link writes it to DDS, and that may fall after MC began. It then crossed in MC (the vehicle's link
    // admits only samples whose DDS source timestamp is at or after the start of MC), so it must be routed in
    // the MC window that directly follows its stamp; one kept across a whole window is not.
    const auto stamped = change_at(trace, static_cast<double>(r.stamp_ns) / 1e9, true);
    const std::size_t next = stamped ? *stamped + 1 : 0;
    EXPECT_EQ(*window, next) << "a sample the planner stamped at " << r.stamp_ns << " ns, in the vehicle's "
                             << mode_at_wall(trace, r.stamp_ns) << ", was routed in a later MC window than the next";
    ++stamped_before_mc;
    if (next < trace.size())
      lead_max_ms = std::max(lead_max_ms, (trace[next].wall_s - static_cast<double>(r.stamp_ns) / 1e9) * 1e3);
  }
  EXPECT_GT(from_planner, 0U);
  std::printf("planner: %zu samples stamped in the vehicle's MC, %zu in its secure interval; %zu routed on the "
              "vehicle (all in MC), %zu of them the planner's, %zu stamped before the MC that carried them (at most "
              "%.1f ms before it began); closest approach %.3f m\n",
              written_in_mc.size(), written_secure.size(), routed.size(), from_planner, stamped_before_mc,
              lead_max_ms, closest_approach(dir_ / "vehicle" / "out" / "trace.csv", wp));
}

}  // namespace
