// The link between hosts, by its effect (docs/across_hosts.md "The link"; root only, skipped otherwise): two network
// namespaces joined by a veth pair stand for the vehicle and the companion; a keystore is made with `rejuv keys`;
// the square of launch/quad_square with SR, on the vehicle's host, and the monitor of monitor.cpp on the
// companion's, each part run by its own `rejuv run --host` kernel in real time. The graph has ROS 2 names
// (`dds { ros2_names: true }`): the keystore grants rt/<topic>, and the links carry the topics under ROS 2's names.
// Checked:
//   - the companion's monitor receives vehicle states, in MC (through link_companion → DDS with DDS Security →
//     link_vehicle);
//   - a Cyclone participant beside the companion's link (rejuv_dds_peer, with the companion's enclave) reading
//     rt/vehicle_state of type rejuv_msgs::msg::dds_::VehicleStateEstimate_ receives what the vehicle's link
//     writes: the link writes under the ROS 2 name and type name;
//   - the vehicle's link is a process of its own (not the kernel) in the vehicle's network namespace;
//   - killed, the link is started again by its kernel (a new pid), and the vehicle stays in its safety set (the
//     run summary's max V < 1);
//   - both runs end by themselves, and no link process is left in either namespace;
//   - tcpdump in the companion's namespace captures the vehicle's packets in MC and none inside a secure interval of
//     the vehicle's flight by its mode trace (its events.csv: CLOCK_MONOTONIC, the capture's CLOCK_REALTIME stamps brought to it).
// No timing is asserted: the runs last as long as they last, the waits are for events.
#include <sys/wait.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "link_fixture.hpp"
#include "rejuv/core/dds_name.hpp"
#include "rejuv/msgs/dds_naming.hpp"
#include "rejuv/services/host_link/host_link.hpp"

namespace {

using namespace rejuv::test_support::across;

const fs::path kTcpdump = "/usr/bin/tcpdump";
const fs::path kPeer = REJUV_DDS_PEER;
constexpr const char* kVehicleAddress = "10.77.0.1";  // as link_fixture.hpp's hosts
constexpr const char* kCompanionAddress = "10.77.0.2";
// The vehicle state as a ROS 2 node sees it: its DDS topic and DDS type names.
const std::string kRos2VehicleState = rejuv::dds_topic_name("vehicle_state", rejuv::DdsNaming::Ros2);
const std::string kRos2StateType = rejuv::msgs::ros2_dds_type_name("rejuv::msg::VehicleStateEstimate");

// The number N of a peer's "received N", or -1 without one.
long long received(const std::string& out) {
  std::smatch m;
  return std::regex_search(out, m, std::regex(R"(received (\d+))")) ? std::stoll(m[1].str()) : -1;
}

// The lines of a kernel's log that tell of faults (a service killed, an image lost, a fallback), for a
// failure's message: the whole log of a 50 s run is too long to read there.
std::string faults_of(const std::string& log) {
  static const std::regex kFault(
      R"(hung|lost|fallback|cold|restart|waiting for a CPU|deadline|left the safety)", std::regex::icase);
  std::string out;
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    if (std::regex_search(line, kFault)) out += line + "\n";
  }
  return out;
}

// CLOCK_REALTIME − CLOCK_MONOTONIC [s] now: what turns a packet's capture stamp into the kernel's wall_s.
double realtime_minus_monotonic() {
  timespec r{}, m{};
  ::clock_gettime(CLOCK_REALTIME, &r);
  ::clock_gettime(CLOCK_MONOTONIC, &m);
  return static_cast<double>(r.tv_sec - m.tv_sec) + static_cast<double>(r.tv_nsec - m.tv_nsec) * 1e-9;
}

// The vehicle's secure intervals of its flight, from its events.csv (kind "mode"; the flight's, after the
// alignment): each [a row not MC, the next MC row). One still open when the run stops is left out: the kernel
// then ends its link and its closure, and what the namespace sends afterwards (ICMP for the link's closed port)
// is no longer the vehicle's. wall_s is CLOCK_MONOTONIC [s].
std::vector<std::pair<double, double>> secure_intervals(const fs::path& events) {
  std::vector<std::pair<double, double>> out;
  std::ifstream in(events);
  std::string line;
  std::getline(in, line);  // t_s,wall_s,kind,epoch,generation,mode,...
  bool closed = false;  // in a secure interval, which began at `began`
  double began = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() < 6 || f[2] != "mode") continue;
    const double wall = std::stod(f[1]);
    if (f[5] == "MC" && closed) {
      out.emplace_back(began, wall);
      closed = false;
    } else if (f[5] != "MC" && !closed) {
      began = wall;
      closed = true;
    }
  }
  return out;
}

class HostLink : public TwoHostsTest {
 protected:
  HostLink() : TwoHostsTest("rjL") {}

  // ROS 2 names: `rejuv keys hosts` grants rt/<topic>, and each kernel gives its links the naming.
  [[nodiscard]] std::string more_graph() const override { return "dds { ros2_names: true }\n"; }

  // rejuv_dds_peer in the companion's namespace with the companion's enclave, configured as its link is
  // (host_link::cyclone_config), reading rt/vehicle_state under ROS 2's type name until its first sample or 10 s.
  CliOutcome observe(const std::string& name) {
    const fs::path cfg = dir_ / (name + ".xml");
    std::ofstream(cfg) << rejuv::services::host_link::cyclone_config({.address = kCompanionAddress,
                                                                      .peers = {kCompanionAddress, kVehicleAddress},
                                                                      .enclave = keys_ / "enclaves" / "companion",
                                                                      .private_key_pem = {}});
    const fs::path d = dir_ / name;
    fs::create_directories(d);
    return rejuv::test_support::run_program(
        d, kIp, {"netns", "exec", companion_ns_, kPeer.string(), "subscribe", kRos2VehicleState, "--names", "ros2",
                 "--domain", std::to_string(domain()), "--config", cfg.string(), "--first", "--seconds", "10"});
  }
};

TEST_F(HostLink, SquareWithACompanion_StatesCrossInMc_LinkRestarted_VehicleSafe) {
  // The companion outlasts the vehicle: it sees the whole flight (each run also aligns for the same 20 s first).
  auto companion = start("companion", 40);
  ASSERT_GT(companion->pid(), 0);
  // The vehicle's packets as the companion's end of the veth sees them, each with its capture stamp.
  const fs::path capture_dir = dir_ / "tcpdump";
  fs::create_directories(capture_dir);
  const double offset_before = realtime_minus_monotonic();
  pid_t capture = rejuv::test_support::start_program(
      capture_dir, kIp, {"netns", "exec", companion_ns_, kTcpdump.string(), "-i", veth_c_, "-n", "-tt", "-l",
                         "--immediate-mode", "src host 10.77.0.1"});
  ASSERT_GT(capture, 0);
  struct KillOnExit {  // a failed assertion leaves no tcpdump behind
    pid_t& pid;
    ~KillOnExit() {
      if (pid > 0 && ::kill(pid, SIGKILL) == 0) (void)::waitpid(pid, nullptr, 0);
    }
  } stop_capture{capture};
  auto vehicle = start("vehicle", 30, false, {"--out", (dir_ / "vehicle_out").string()});
  ASSERT_GT(vehicle->pid(), 0);

  // The vehicle's link: a process of its own, the kernel's child, in the vehicle's network namespace.
  std::set<pid_t> first;
  ASSERT_TRUE(until(*vehicle, [&] { return !(first = links_of(vehicle->pid())).empty(); })) << vehicle->err();
  ASSERT_EQ(first.size(), 1U);
  const pid_t link = *first.begin();
  EXPECT_NE(link, vehicle->pid());
  const ino_t vehicle_ns = netns_inode(fs::path("/run/netns") / vehicle_ns_);
  ASSERT_NE(vehicle_ns, 0U);
  EXPECT_EQ(netns_inode(fs::path("/proc") / std::to_string(link) / "ns" / "net"), vehicle_ns);
  EXPECT_NE(netns_inode("/proc/self/ns/net"), vehicle_ns);

  // The monitor on the companion gets vehicle states, in MC; then the link is killed.
  ASSERT_TRUE(until(*companion, [&] { return received_in_mc(companion->err()) > 0; })) << companion->err();
  ASSERT_EQ(::kill(link, SIGKILL), 0);
  std::set<pid_t> again;
  ASSERT_TRUE(until(*vehicle, [&] {
    again = links_of(vehicle->pid());
    return !again.empty() && again.count(link) == 0;
  })) << vehicle->err();
  EXPECT_EQ(netns_inode(fs::path("/proc") / std::to_string(*again.begin()) / "ns" / "net"), vehicle_ns);

  // The vehicle's (restarted) link writes under ROS 2's names: a participant beside the companion's link reads
  // rt/vehicle_state of rejuv_msgs::msg::dds_::VehicleStateEstimate_ and receives. One after another, each until
  // its first sample or 10 s, while the vehicle flies, until one receives (each needs its DDS Security handshake
  // with the vehicle's link, which is open only in MC).
  int observers = 0;
  long long observed = 0;
  CliOutcome observer;
  while (observed <= 0 && !vehicle->ended()) {
    observer = observe("observer_" + std::to_string(++observers));
    ASSERT_NE(observer.out.find("reading " + kRos2VehicleState + " as " + kRos2StateType), std::string::npos)
        << observer.out << observer.err;
    observed = received(observer.out);
  }
  EXPECT_GT(observed, 0) << observers << " participant(s) reading " << kRos2VehicleState << " received nothing:\n"
                         << observer.out << observer.err;
  std::printf("a participant beside the companion's link received the vehicle's %s (%s) after %d participant(s)\n",
              kRos2VehicleState.c_str(), kRos2StateType.c_str(), observers);

  const CliOutcome v = vehicle->wait();
  const CliOutcome c = companion->wait();
  ::kill(capture, SIGINT);
  const CliOutcome captured = rejuv::test_support::wait_program(capture_dir, std::exchange(capture, -1));
  const double offset = (offset_before + realtime_minus_monotonic()) / 2;
  const auto closed = secure_intervals(dir_ / "vehicle_out" / "events.csv");
  ASSERT_FALSE(closed.empty());
  // A packet stamped within 2 ms of a mode change is not judged: the closure and the mode row are a few
  // microseconds apart, and the stamps of two clocks.
  constexpr double kEdge = 0.002;
  std::size_t in_mc = 0, in_secure_interval = 0;
  std::string first_inside;
  std::istringstream packets(captured.out);
  for (std::string line; std::getline(packets, line);) {
    if (line.find(" IP 10.77.0.1") == std::string::npos) continue;
    const double t = std::stod(line) - offset;
    const bool inside = std::any_of(closed.begin(), closed.end(), [&](const auto& w) {
      return t > w.first + kEdge && t < w.second - kEdge;
    });
    const bool edge = std::any_of(closed.begin(), closed.end(), [&](const auto& w) {
      return std::abs(t - w.first) <= kEdge || std::abs(t - w.second) <= kEdge;
    });
    if (inside) {
      if (in_secure_interval++ < 5) {
        const auto w = std::find_if(closed.begin(), closed.end(), [&](const auto& x) { return t > x.first && t < x.second; });
        first_inside += "\n  " + line + " at " + std::to_string(t) + " in [" + std::to_string(w->first) + ", " +
                        std::to_string(w->second) + ")";
      }
    } else if (!edge && t > closed.front().first && t < closed.back().second) {  // an MC window of the flight
      ++in_mc;
    }
  }
  std::printf("tcpdump in the companion's namespace: %zu of the vehicle's packets in its MC windows, %zu in its %zu "
              "secure intervals\n", in_mc, in_secure_interval, closed.size());
  EXPECT_GT(in_mc, 0U) << "the capture saw none of the vehicle's packets in MC: " << captured.err;
  EXPECT_EQ(in_secure_interval, 0U) << "inside:" << first_inside << "\n" << " (" << closed.size() << " secure intervals)";
  EXPECT_NE(v.err.find("service 'link_companion' restarted from its binary"), std::string::npos) << v.err;
  // The vehicle stayed in its safety set: the run summary's max V below 1.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(v.out, m, std::regex(R"(max V = ([0-9.]+))"))) << v.out;
  EXPECT_LT(std::stod(m[1].str()), 1.0) << v.out << "\nthe vehicle kernel's faults:\n" << faults_of(v.err);
  EXPECT_GT(received_in_mc(c.err), 0) << c.err;
  EXPECT_EQ(c.exit_code, 0) << c.out << c.err;
  // Nothing left behind: no link in either namespace.
  EXPECT_TRUE(links_in(vehicle_ns).empty());
  EXPECT_TRUE(links_in(netns_inode(fs::path("/run/netns") / companion_ns_)).empty());
}

}  // namespace
