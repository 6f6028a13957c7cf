// DDS Security generated from the policy, shown by its effect between two hosts (docs/across_hosts.md): two
// network namespaces joined by a veth pair stand for the vehicle and the companion of
// tests/across_hosts/companion.launch.pbtxt; `rejuv keys` makes the keystore; one Cyclone DDS participant per
// process (rejuv_dds_peer, `ip netns exec`) in each. A topic the policy makes cross (state: vehicle → companion)
// is delivered; a writer on a topic the host was not granted is refused by Cyclone ("Not Allowed By Security");
// a participant without security, beside a secure one that receives, receives nothing (where two participants
// without security do exchange the topic: the control). Root only (network
// namespaces); skipped otherwise with the reason. Namespaces and processes are removed on every exit path.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "keystore.hpp"
#include "rejuv/core/cyclone_xml.hpp"

namespace {

using rejuv::test_support::CliOutcome;
using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
namespace fs = std::filesystem;

const fs::path kIp = "/usr/sbin/ip";
const fs::path kPeer = REJUV_DDS_PEER;
const std::string kGraph = (kRepo / "tests" / "across_hosts" / "companion.launch.pbtxt").string();
constexpr const char* kVehicleAddress = "10.77.0.1";  // as the graph's hosts
constexpr const char* kCompanionAddress = "10.77.0.2";

// A peer process; killed and reaped if the test leaves before it ended.
class Peer {
 public:
  Peer(fs::path dir, pid_t pid) : dir_(std::move(dir)), pid_(pid) {}
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;
  ~Peer() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  // Waits for its end (every peer ends by itself within its --seconds).
  CliOutcome wait() { return rejuv::test_support::wait_program(dir_, std::exchange(pid_, -1)); }
  CliOutcome stop() {
    ::kill(pid_, SIGTERM);
    return wait();
  }
  // Waits until it printed `line` or ended; true if printed.
  bool printed(const std::string& line) const {
    for (;;) {
      if (slurp(dir_ / "stdout").find(line) != std::string::npos) return true;
      siginfo_t info{};
      if (::waitid(P_PID, static_cast<id_t>(pid_), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid_) {
        return slurp(dir_ / "stdout").find(line) != std::string::npos;
      }
      ::usleep(10'000);
    }
  }

 private:
  fs::path dir_;
  pid_t pid_;
};

class AcrossHosts : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (::geteuid() != 0) return;
    dir_ = fs::temp_directory_path() / ("rejuv_across_hosts_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "cmd");
    remove_stale_namespaces();
    const std::string id = std::to_string(::getpid());
    vehicle_ns_ = "rjv_" + id;
    companion_ns_ = "rjc_" + id;
    const std::string veth_v = "rjv" + id, veth_c = "rjc" + id;  // ≤ 15 characters
    ns_made_ = true;
    for (const std::vector<std::string>& cmd :
         {std::vector<std::string>{"netns", "add", vehicle_ns_}, {"netns", "add", companion_ns_},
          {"link", "add", veth_v, "type", "veth", "peer", "name", veth_c},
          {"link", "set", veth_v, "netns", vehicle_ns_}, {"link", "set", veth_c, "netns", companion_ns_},
          {"-n", vehicle_ns_, "addr", "add", std::string(kVehicleAddress) + "/24", "dev", veth_v},
          {"-n", companion_ns_, "addr", "add", std::string(kCompanionAddress) + "/24", "dev", veth_c},
          {"-n", vehicle_ns_, "link", "set", veth_v, "up"}, {"-n", companion_ns_, "link", "set", veth_c, "up"},
          {"-n", vehicle_ns_, "link", "set", "lo", "up"}, {"-n", companion_ns_, "link", "set", "lo", "up"}}) {
      const CliOutcome r = rejuv::test_support::run_program(dir_ / "cmd", kIp, cmd);
      if (r.exit_code != 0) {
        setup_error_ = "ip " + cmd[0] + " " + cmd[1] + " ...: " + r.err;
        return;
      }
    }
    const fs::path store = dir_ / "keystore";
    for (const std::vector<std::string>& cmd :
         {std::vector<std::string>{"keys", "init", store.string()},
          {"keys", "hosts", store.string(), "--launch", kGraph, "--domain", std::to_string(domain())}}) {
      const CliOutcome r = rejuv::test_support::run_rejuv(dir_ / "cmd", cmd);
      if (r.exit_code != 0) {
        setup_error_ = "rejuv keys " + cmd[1] + ": " + r.err;
        return;
      }
    }
  }
  // Namespaces of an earlier run of this test that was killed before its tear-down (rjv_<pid>, rjc_<pid> of a
  // process that no longer exists): removed, so that no kill leaves them behind for good.
  static void remove_stale_namespaces() {
    const CliOutcome list = rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "list"});
    std::istringstream lines(list.out);
    for (std::string line; std::getline(lines, line);) {
      const std::string ns = line.substr(0, line.find(' '));
      if (ns.size() < 5 || (ns.rfind("rjv_", 0) != 0 && ns.rfind("rjc_", 0) != 0)) continue;
      const std::string pid = ns.substr(4);
      if (pid.find_first_not_of("0123456789") != std::string::npos) continue;
      if (fs::exists("/proc/" + pid)) continue;  // a live run's
      (void)rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "delete", ns});
    }
  }

  static void TearDownTestSuite() {
    if (ns_made_) {
      // Deleting a namespace deletes the veth end in it, and with it the pair.
      for (const std::string& ns : {vehicle_ns_, companion_ns_}) {
        (void)rejuv::test_support::run_program(dir_ / "cmd", kIp, {"netns", "delete", ns});
      }
    }
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: it makes network namespaces and a veth pair (ip netns)";
    ASSERT_TRUE(setup_error_.empty()) << setup_error_;
  }

  static std::uint32_t domain() { return rejuv::test_support::kOwnDdsDomain; }

  // The Cyclone XML of one participant: its own address, both hosts as unicast peers, and the enclave of
  // `enclave` ("" = no security).
  static fs::path config(const std::string& name, const char* address, const std::string& enclave) {
    const fs::path file = dir_ / (name + ".xml");
    std::ofstream(file) << rejuv::cyclone::config_xml(rejuv::cyclone::ParticipantConfig{
                               .address = address,
                               .peers = {kVehicleAddress, kCompanionAddress},
                               .enclave = enclave.empty() ? fs::path() : dir_ / "keystore" / "enclaves" / enclave})
                        << "\n";
    return file;
  }

  // Starts rejuv_dds_peer in `ns` as `name` (its output in a folder of that name).
  static std::unique_ptr<Peer> start(const std::string& name, const std::string& ns, const std::string& role,
                                     const std::string& topic, const fs::path& cfg, std::vector<std::string> extra = {}) {
    const fs::path d = dir_ / name;
    fs::create_directories(d);
    std::vector<std::string> args{"netns", "exec", ns, kPeer.string(), role, topic, "--domain",
                                  std::to_string(domain()), "--config", cfg.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return std::make_unique<Peer>(d, rejuv::test_support::start_program(d, kIp, args));
  }

  static inline fs::path dir_;
  static inline std::string vehicle_ns_, companion_ns_, setup_error_;
  static inline bool ns_made_ = false;
};

TEST_F(AcrossHosts, GrantedCrossHostTopic_Delivered) {
  auto sub = start("granted_sub", companion_ns_, "subscribe", "rejuv/state",
                   config("granted_sub", kCompanionAddress, "companion"), {"--first", "--seconds", "60"});
  ASSERT_TRUE(sub->printed("reading")) << slurp(dir_ / "granted_sub" / "stdout") << slurp(dir_ / "granted_sub" / "stderr");
  auto pub = start("granted_pub", vehicle_ns_, "publish", "rejuv/state",
                   config("granted_pub", kVehicleAddress, "vehicle"), {"--seconds", "60"});
  ASSERT_TRUE(pub->printed("writing")) << slurp(dir_ / "granted_pub" / "stdout") << slurp(dir_ / "granted_pub" / "stderr");
  const CliOutcome got = sub->wait();
  EXPECT_EQ(got.exit_code, 0) << got.err;
  EXPECT_NE(got.out.find("received 1"), std::string::npos) << got.out << got.err;
  (void)pub->stop();
}

TEST_F(AcrossHosts, WriterOnUngrantedTopic_NotAllowedBySecurity) {
  // telemetry is read on the vehicle only: no host may carry it. state is the companion's to read, not write.
  for (const auto& [name, ns, address, enclave, topic] :
       {std::tuple{"ungranted_vehicle", vehicle_ns_, kVehicleAddress, "vehicle", "rejuv/telemetry"},
        std::tuple{"ungranted_companion", companion_ns_, kCompanionAddress, "companion", "rejuv/state"}}) {
    SCOPED_TRACE(name);
    auto pub = start(name, ns, "publish", topic, config(name, address, enclave), {"--seconds", "60"});
    const CliOutcome r = pub->wait();
    EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
    EXPECT_NE(r.out.find("refused: "), std::string::npos) << r.out << r.err;
    EXPECT_NE(r.out.find("Not Allowed By Security"), std::string::npos) << r.out << r.err;
  }
}

TEST_F(AcrossHosts, ParticipantWithoutSecurity_ReceivesNothing) {
  auto plain = start("plain_sub", companion_ns_, "subscribe", "rejuv/state",
                     config("plain_sub", kCompanionAddress, ""), {"--seconds", "120"});
  ASSERT_TRUE(plain->printed("reading")) << slurp(dir_ / "plain_sub" / "stderr");
  auto pub = start("plain_pub", vehicle_ns_, "publish", "rejuv/state", config("plain_pub", kVehicleAddress, "vehicle"),
                   {"--seconds", "120"});
  ASSERT_TRUE(pub->printed("writing")) << slurp(dir_ / "plain_pub" / "stderr");
  // Two secure subscribers in turn, beside the plain one, each until its first sample: the vehicle's samples
  // reached the companion's namespace, twice over, while the plain participant listened there.
  for (const std::string name : {"secure_sub_1", "secure_sub_2"}) {
    auto secure = start(name, companion_ns_, "subscribe", "rejuv/state", config(name, kCompanionAddress, "companion"),
                        {"--first", "--seconds", "60"});
    const CliOutcome got = secure->wait();
    ASSERT_NE(got.out.find("received 1"), std::string::npos) << name << ": " << got.out << got.err;
  }
  const CliOutcome nothing = plain->stop();
  EXPECT_NE(nothing.out.find("received 0"), std::string::npos) << nothing.out << nothing.err;
  (void)pub->stop();
}

// The control of the test above: between two participants without security the same path delivers, so the
// plain participant's nothing is the security's doing, not the network's.
TEST_F(AcrossHosts, WithoutSecurityOnBothSides_Delivered) {
  auto sub = start("open_sub", companion_ns_, "subscribe", "rejuv/state", config("open_sub", kCompanionAddress, ""),
                   {"--first", "--seconds", "60"});
  ASSERT_TRUE(sub->printed("reading")) << slurp(dir_ / "open_sub" / "stderr");
  auto pub = start("open_pub", vehicle_ns_, "publish", "rejuv/state", config("open_pub", kVehicleAddress, ""),
                   {"--seconds", "60"});
  const CliOutcome got = sub->wait();
  EXPECT_NE(got.out.find("received 1"), std::string::npos) << got.out << got.err;
  (void)pub->stop();
}

}  // namespace
