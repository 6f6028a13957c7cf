// The set-up of the tests of the link between hosts (link_test.cpp, hostile_link_test.cpp; docs/across_hosts.md
// "The link"; root only, skipped otherwise): two network namespaces joined by a veth pair stand for the vehicle
// (10.77.0.1) and the companion (10.77.0.2); a keystore is made with `rejuv keys`; the graph is the square of
// launch/quad_square with SR on the vehicle's host and the monitor of monitor.cpp on the companion's, each part
// run by its own `rejuv run --host` kernel (start). The namespaces (and with them the veth pair and any nftables
// table in them) and the test's folder are removed in TearDown, also when the test failed. A test target that
// includes this defines REJUV_ACROSS_MONITOR (the monitor's executable).
#pragma once

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
#include <utility>
#include <vector>

#include "../netns_pair.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"

namespace rejuv::test_support::across {

using rejuv::test_support::CliOutcome;
using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
namespace fs = std::filesystem;

inline const fs::path kIp = "/usr/sbin/ip";
inline const fs::path kMonitor = REJUV_ACROSS_MONITOR;

// The inode of a network namespace (/run/netns/<name> or /proc/<pid>/ns/net); 0 when it cannot be read.
inline ino_t netns_inode(const fs::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 ? st.st_ino : 0;
}

// The pids of the rejuv_host_link processes whose parent is `kernel`.
inline std::set<pid_t> links_of(pid_t kernel) {
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
inline std::set<pid_t> links_in(ino_t ns) {
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
inline long long received_in_mc(const std::string& log) {
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

class TwoHostsTest : public ::testing::Test {
 protected:
  // `prefix` (3 characters, the test's own) names the namespaces and veth ends (NetnsPair).
  explicit TwoHostsTest(std::string prefix) : prefix_(std::move(prefix)) {}

  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: it makes network namespaces and a veth pair (ip netns)";
    const std::string id = std::to_string(::getpid());
    dir_ = fs::temp_directory_path() / ("rejuv_" + prefix_ + "_test_" + id);
    fs::create_directories(dir_ / "cmd");
    hosts_.emplace(dir_ / "cmd", prefix_);
    const std::string error = hosts_->make("10.77.0.1", "10.77.0.2");
    ASSERT_TRUE(error.empty()) << error;
    vehicle_ns_ = hosts_->vehicle;
    companion_ns_ = hosts_->companion;
    veth_c_ = hosts_->companion_veth;
    // The square with SR on the vehicle, the monitor on the companion; each host's link in its namespace.
    graph_ = dir_ / "quad_companion.launch.pbtxt";
    std::ofstream(graph_) << "include: \"" << (kRepo / "launch" / "quad_square.launch.pbtxt").string() << "\"\n"
                          << "policy_include: \"" << (kRepo / "tests" / "across_hosts" / "monitor.policy.pbtxt").string() << "\"\n"
                          << "hosts { name: \"vehicle\" address: \"10.77.0.1\" netns: \"" << vehicle_ns_ << "\" }\n"
                          << "hosts { name: \"companion\" address: \"10.77.0.2\" netns: \"" << companion_ns_ << "\" }\n"
                          << "services { name: \"monitor\" executable: \"" << kMonitor.string() << "\" host: \"companion\"\n"
                          << "  uses { object: \"vehicle_state\" rights: \"R\" } }\n"
                          << more_graph();
    keys_ = dir_ / "keys";
    for (const std::vector<std::string>& cmd :
         {std::vector<std::string>{"keys", "init", keys_.string()},
          {"keys", "hosts", keys_.string(), "--launch", graph_.string(), "--domain", std::to_string(domain())}}) {
      const CliOutcome r = rejuv::test_support::run_rejuv(dir_ / "cmd", cmd);
      ASSERT_EQ(r.exit_code, 0) << "rejuv keys " << cmd[1] << ": " << r.err;
    }
  }
  void TearDown() override {
    hosts_.reset();  // before its folder goes
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }

  // What a test adds to the graph (services, policy includes), written before the keystore is made from it.
  [[nodiscard]] virtual std::string more_graph() const { return {}; }

  static std::uint32_t domain() { return rejuv::test_support::kOwnDdsDomain; }

  // `rejuv run GRAPH --host HOST` for `seconds` of flight, its output in a folder of the host's name. With
  // `own_session` it runs under setsid(1) (exec'ed in place: the same pid), the leader of a process group of its
  // own, which a test may then kill as a whole.
  // `extra`: more options of `rejuv run` (e.g. --out DIR).
  std::unique_ptr<KernelRun> start(const std::string& host, int seconds, bool own_session = false,
                                   const std::vector<std::string>& extra = {}) {
    const fs::path d = dir_ / host;
    fs::create_directories(d);
    std::vector<std::string> args{"run", graph_.string(), "--host", host, "--keys", keys_.string(),
                                  "--domain", std::to_string(domain()), "--duration", std::to_string(seconds)};
    args.insert(args.end(), extra.begin(), extra.end());
    if (own_session) args.insert(args.begin(), rejuv::test_support::kRejuv.string());
    return std::make_unique<KernelRun>(
        d, rejuv::test_support::start_program(d, own_session ? fs::path("/usr/bin/setsid") : rejuv::test_support::kRejuv,
                                              std::move(args)));
  }

  std::string prefix_;
  fs::path dir_, graph_, keys_;
  std::optional<rejuv::test_support::NetnsPair> hosts_;
  // hosts_'s names, as the tests use them: the namespaces and the companion's veth end.
  std::string vehicle_ns_, companion_ns_, veth_c_;
};

}  // namespace rejuv::test_support::across
