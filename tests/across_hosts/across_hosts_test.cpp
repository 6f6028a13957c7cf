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
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "../netns_pair.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "keystore.hpp"
#include "rejuv/core/cyclone_xml.hpp"
#include "rejuv/core/dds_name.hpp"

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
// The graph's topics under their DDS names (the names the keystore's permissions grant).
const std::string kState = rejuv::dds_topic_name("state", rejuv::DdsNaming::Rejuv);
const std::string kTelemetry = rejuv::dds_topic_name("telemetry", rejuv::DdsNaming::Rejuv);

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
    hosts_.emplace(dir_ / "cmd", "rj");
    setup_error_ = hosts_->make(kVehicleAddress, kCompanionAddress);
    if (!setup_error_.empty()) return;
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
  static void TearDownTestSuite() {
    hosts_.reset();  // before its folder goes
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
  static inline std::optional<rejuv::test_support::NetnsPair> hosts_;
  static inline std::string setup_error_;
};

TEST_F(AcrossHosts, GrantedCrossHostTopic_Delivered) {
  auto sub = start("granted_sub", hosts_->companion, "subscribe", kState,
                   config("granted_sub", kCompanionAddress, "companion"), {"--first", "--seconds", "60"});
  ASSERT_TRUE(sub->printed("reading")) << slurp(dir_ / "granted_sub" / "stdout") << slurp(dir_ / "granted_sub" / "stderr");
  auto pub = start("granted_pub", hosts_->vehicle, "publish", kState,
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
       {std::tuple{"ungranted_vehicle", hosts_->vehicle, kVehicleAddress, "vehicle", kTelemetry},
        std::tuple{"ungranted_companion", hosts_->companion, kCompanionAddress, "companion", kState}}) {
    SCOPED_TRACE(name);
    auto pub = start(name, ns, "publish", topic, config(name, address, enclave), {"--seconds", "60"});
    const CliOutcome r = pub->wait();
    EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
    EXPECT_NE(r.out.find("refused: "), std::string::npos) << r.out << r.err;
    EXPECT_NE(r.out.find("Not Allowed By Security"), std::string::npos) << r.out << r.err;
  }
}

TEST_F(AcrossHosts, ParticipantWithoutSecurity_ReceivesNothing) {
  auto plain = start("plain_sub", hosts_->companion, "subscribe", kState,
                     config("plain_sub", kCompanionAddress, ""), {"--seconds", "120"});
  ASSERT_TRUE(plain->printed("reading")) << slurp(dir_ / "plain_sub" / "stderr");
  auto pub = start("plain_pub", hosts_->vehicle, "publish", kState, config("plain_pub", kVehicleAddress, "vehicle"),
                   {"--seconds", "120"});
  ASSERT_TRUE(pub->printed("writing")) << slurp(dir_ / "plain_pub" / "stderr");
  // Two secure subscribers in turn, beside the plain one, each until its first sample: the vehicle's samples
  // reached the companion's namespace, twice over, while the plain participant listened there.
  for (const std::string name : {"secure_sub_1", "secure_sub_2"}) {
    auto secure = start(name, hosts_->companion, "subscribe", kState, config(name, kCompanionAddress, "companion"),
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
  auto sub = start("open_sub", hosts_->companion, "subscribe", kState, config("open_sub", kCompanionAddress, ""),
                   {"--first", "--seconds", "60"});
  ASSERT_TRUE(sub->printed("reading")) << slurp(dir_ / "open_sub" / "stderr");
  auto pub = start("open_pub", hosts_->vehicle, "publish", kState, config("open_pub", kVehicleAddress, ""),
                   {"--seconds", "60"});
  const CliOutcome got = sub->wait();
  EXPECT_NE(got.out.find("received 1"), std::string::npos) << got.out << got.err;
  (void)pub->stop();
}

}  // namespace
