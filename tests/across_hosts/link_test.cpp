// The link between hosts, by its effect (docs/across_hosts.md "The link"; root only, skipped otherwise): two network
// namespaces joined by a veth pair stand for the vehicle and the companion; a keystore is made with `rejuv keys`;
// the square of launch/quad_square with SR, on the vehicle's host, and the monitor of monitor.cpp on the
// companion's, each part run by its own `rejuv run --host` kernel in real time. Checked:
//   - the companion's monitor receives vehicle states, in MC (through link_companion → DDS with DDS Security →
//     link_vehicle);
//   - the vehicle's link is a process of its own (not the kernel) in the vehicle's network namespace;
//   - killed, the link is started again by its kernel (a new pid), and the vehicle stays in its safety set (the
//     run summary's max V < 1);
//   - both runs end by themselves, and no link process is left in either namespace.
// No timing is asserted: the runs last as long as they last, the waits are for events.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"

namespace {

using rejuv::test_support::CliOutcome;
using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
namespace fs = std::filesystem;

const fs::path kIp = "/usr/sbin/ip";
const fs::path kMonitor = REJUV_ACROSS_MONITOR;

// The inode of a network namespace (/run/netns/<name> or /proc/<pid>/ns/net); 0 when it cannot be read.
ino_t netns_inode(const fs::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 ? st.st_ino : 0;
}

// The pids of the rejuv_host_link processes whose parent is `kernel`.
std::set<pid_t> links_of(pid_t kernel) {
  std::set<pid_t> out;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream status(e.path() / "status");
    std::string line, comm;
    pid_t ppid = 0;
    while (std::getline(status, line)) {
      if (line.rfind("Name:", 0) == 0) comm = line.substr(line.find_first_not_of(" \t", 5));
      if (line.rfind("PPid:", 0) == 0) ppid = static_cast<pid_t>(std::atoi(line.c_str() + 5));
    }
    if (comm == "rejuv_host_link" && ppid == kernel) out.insert(static_cast<pid_t>(std::atoi(name.c_str())));
  }
  return out;
}

// Every rejuv_host_link process in the network namespace of inode `ns`.
std::set<pid_t> links_in(ino_t ns) {
  std::set<pid_t> out;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    if (slurp(e.path() / "comm").rfind("rejuv_host_link", 0) != 0) continue;
    if (netns_inode(e.path() / "ns" / "net") == ns) out.insert(static_cast<pid_t>(std::atoi(name.c_str())));
  }
  return out;
}

// The last "vehicle states received: N (in MC: M)" of the monitor in `log`: M, or -1 before the first.
long long received_in_mc(const std::string& log) {
  static const std::regex line(R"(vehicle states received: \d+ \(in MC: (\d+)\))");
  long long last = -1;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), line); it != std::sregex_iterator(); ++it) {
    last = std::stoll((*it)[1].str());
  }
  return last;
}

// A run of `rejuv run`, stopped (SIGTERM, then SIGKILL) and reaped if the test leaves before it ended.
class KernelRun {
 public:
  KernelRun(fs::path dir, pid_t pid) : dir_(std::move(dir)), pid_(pid) {}
  KernelRun(const KernelRun&) = delete;
  KernelRun& operator=(const KernelRun&) = delete;
  ~KernelRun() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    for (int i = 0; i < 100; ++i) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) return;
      ::usleep(100'000);
    }
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
  }
  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] std::string err() const { return slurp(dir_ / "stderr"); }
  [[nodiscard]] bool ended() const {
    siginfo_t info{};
    return ::waitid(P_PID, static_cast<id_t>(pid_), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid_;
  }
  CliOutcome wait() { return rejuv::test_support::wait_program(dir_, std::exchange(pid_, -1)); }

 private:
  fs::path dir_;
  pid_t pid_;
};

// Polls `done` every 50 ms until it holds or `run` has ended; true if it held.
template <class F>
bool until(const KernelRun& run, F done) {
  for (;;) {
    if (done()) return true;
    if (run.ended()) return done();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

class HostLink : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: it makes network namespaces and a veth pair (ip netns)";
    const std::string id = std::to_string(::getpid());
    dir_ = fs::temp_directory_path() / ("rejuv_host_link_test_" + id);
    fs::create_directories(dir_ / "cmd");
    remove_stale_namespaces();
    vehicle_ns_ = "rjL_v" + id;
    companion_ns_ = "rjL_c" + id;
    const std::string veth_v = "rjLv" + id, veth_c = "rjLc" + id;  // ≤ 15 characters
    made_ = true;
    for (const std::vector<std::string>& cmd :
         {std::vector<std::string>{"netns", "add", vehicle_ns_}, {"netns", "add", companion_ns_},
          {"link", "add", veth_v, "type", "veth", "peer", "name", veth_c},
          {"link", "set", veth_v, "netns", vehicle_ns_}, {"link", "set", veth_c, "netns", companion_ns_},
          {"-n", vehicle_ns_, "addr", "add", "10.77.0.1/24", "dev", veth_v},
          {"-n", companion_ns_, "addr", "add", "10.77.0.2/24", "dev", veth_c},
          {"-n", vehicle_ns_, "link", "set", veth_v, "up"}, {"-n", companion_ns_, "link", "set", veth_c, "up"},
          {"-n", vehicle_ns_, "link", "set", "lo", "up"}, {"-n", companion_ns_, "link", "set", "lo", "up"}}) {
      const CliOutcome r = rejuv::test_support::run_program(dir_ / "cmd", kIp, cmd);
      ASSERT_EQ(r.exit_code, 0) << "ip " << cmd[0] << " " << cmd[1] << " ...: " << r.err;
    }
    // The square with SR on the vehicle, the monitor on the companion; each host's link in its namespace.
    graph_ = dir_ / "quad_companion.launch.pbtxt";
    std::ofstream(graph_) << "include: \"" << (kRepo / "launch" / "quad_square.launch.pbtxt").string() << "\"\n"
                          << "policy_include: \"" << (kRepo / "tests" / "across_hosts" / "monitor.policy.pbtxt").string() << "\"\n"
                          << "hosts { name: \"vehicle\" address: \"10.77.0.1\" netns: \"" << vehicle_ns_ << "\" }\n"
                          << "hosts { name: \"companion\" address: \"10.77.0.2\" netns: \"" << companion_ns_ << "\" }\n"
                          << "services { name: \"monitor\" executable: \"" << kMonitor.string() << "\" host: \"companion\"\n"
                          << "  uses { object: \"vehicle_state\" rights: \"R\" } }\n";
    keys_ = dir_ / "keys";
    for (const std::vector<std::string>& cmd :
         {std::vector<std::string>{"keys", "init", keys_.string()},
          {"keys", "hosts", keys_.string(), "--launch", graph_.string(), "--domain", std::to_string(domain())}}) {
      const CliOutcome r = rejuv::test_support::run_rejuv(dir_ / "cmd", cmd);
      ASSERT_EQ(r.exit_code, 0) << "rejuv keys " << cmd[1] << ": " << r.err;
    }
  }
  // Namespaces of an earlier run of this test killed before its tear-down (rjL_v<pid>, rjL_c<pid> of a process
  // that no longer exists): removed, so that no kill leaves them behind for good.
  void remove_stale_namespaces() {
    const CliOutcome list = rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "list"});
    std::istringstream lines(list.out);
    for (std::string line; std::getline(lines, line);) {
      const std::string ns = line.substr(0, line.find(' '));
      if (ns.size() < 6 || (ns.rfind("rjL_v", 0) != 0 && ns.rfind("rjL_c", 0) != 0)) continue;
      const std::string pid = ns.substr(5);
      if (pid.find_first_not_of("0123456789") != std::string::npos || fs::exists("/proc/" + pid)) continue;
      (void)rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "delete", ns});
    }
  }

  void TearDown() override {
    if (made_) {
      // Deleting a namespace deletes the veth end in it, and with it the pair.
      for (const std::string& ns : {vehicle_ns_, companion_ns_}) {
        (void)rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "delete", ns});
      }
    }
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }

  static std::uint32_t domain() { return rejuv::test_support::kOwnDdsDomain; }

  // `rejuv run GRAPH --host HOST` for `seconds` of flight, its output in a folder of the host's name.
  std::unique_ptr<KernelRun> start(const std::string& host, int seconds) {
    const fs::path d = dir_ / host;
    fs::create_directories(d);
    return std::make_unique<KernelRun>(
        d, rejuv::test_support::start_program(d, rejuv::test_support::kRejuv,
                                              {"run", graph_.string(), "--host", host, "--keys", keys_.string(),
                                               "--domain", std::to_string(domain()), "--duration",
                                               std::to_string(seconds)}));
  }

  fs::path dir_, graph_, keys_;
  std::string vehicle_ns_, companion_ns_;
  bool made_ = false;
};

TEST_F(HostLink, SquareWithACompanion_StatesCrossInMc_LinkRestarted_VehicleSafe) {
  // The companion outlasts the vehicle: it sees the whole flight (each run also aligns for the same 20 s first).
  auto companion = start("companion", 40);
  ASSERT_GT(companion->pid(), 0);
  auto vehicle = start("vehicle", 30);
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

  const CliOutcome v = vehicle->wait();
  const CliOutcome c = companion->wait();
  EXPECT_NE(v.err.find("service 'link_companion' restarted from its binary"), std::string::npos) << v.err;
  // The vehicle stayed in its safety set: the run summary's max V below 1.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(v.out, m, std::regex(R"(max V = ([0-9.]+))"))) << v.out;
  EXPECT_LT(std::stod(m[1].str()), 1.0) << v.out;
  EXPECT_GT(received_in_mc(c.err), 0) << c.err;
  EXPECT_EQ(c.exit_code, 0) << c.out << c.err;
  // Nothing left behind: no link in either namespace.
  EXPECT_TRUE(links_in(vehicle_ns).empty());
  EXPECT_TRUE(links_in(netns_inode(fs::path("/run/netns") / companion_ns_)).empty());
}

}  // namespace
