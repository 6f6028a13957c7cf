// `rejuv keys` (docs/across_hosts.md): the DDS Security keystore of a graph across hosts, as a user makes it.
// The CA is made once and never overwritten; each host's enclave holds an identity of its CN issued by the CA,
// key files are 0600, and its permissions grant exactly the policy's crossings of that host, signed by the CA
// (checked with libcrypto against the CA, and refused once a byte of the signed document changes). Bad input
// exits 2 with what is wrong. Fixture: tests/across_hosts/companion.{policy,launch}.pbtxt.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../../rejuv_cli.hpp"
#include "keystore.hpp"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
namespace fs = std::filesystem;

const std::string kGraph = (kRepo / "tests" / "across_hosts" / "companion.launch.pbtxt").string();

class Keys : public rejuv::test_support::ScratchDirTest {
 protected:
  Keys() : ScratchDirTest("rejuv_keys_test_") {}
  rejuv::test_support::CliOutcome rejuv(const std::vector<std::string>& args) const {
    return rejuv::test_support::run_rejuv(dir_ / "cli", args);
  }
  void SetUp() override {
    ScratchDirTest::SetUp();
    fs::create_directories(dir_ / "cli");
  }
  [[nodiscard]] fs::path store() const { return dir_ / "keystore"; }
};

unsigned mode_of(const fs::path& p) {
  struct ::stat st {};
  EXPECT_EQ(::stat(p.c_str(), &st), 0) << p;
  return st.st_mode & 0777U;
}

TEST_F(Keys, Init_MakesCaWithSecretKey_AndRefusesToOverwriteIt) {
  const auto first = rejuv({"keys", "init", store().string()});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_EQ(mode_of(store() / "private" / "ca.key.pem"), 0600U);
  EXPECT_EQ(mode_of(store() / "private"), 0700U);
  EXPECT_TRUE(fs::exists(store() / "public" / "identity_ca.cert.pem"));
  EXPECT_TRUE(fs::exists(store() / "public" / "permissions_ca.cert.pem"));
  const std::string ca = slurp(store() / "public" / "ca.cert.pem");
  const auto second = rejuv({"keys", "init", store().string()});
  EXPECT_EQ(second.exit_code, 2);
  EXPECT_NE(second.err.find("holds a CA; refusing to overwrite it"), std::string::npos) << second.err;
  EXPECT_EQ(slurp(store() / "public" / "ca.cert.pem"), ca);  // untouched
}

TEST_F(Keys, Hosts_PermissionsGrantExactlyEachHostsCrossings_SignedByTheCa) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  const auto r = rejuv({"keys", "hosts", store().string(), "--launch", kGraph, "--domain", "7"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  struct Expect {
    std::string host, publish, subscribe, denied;
  };
  for (const Expect& e : {Expect{"vehicle", "rejuv/state", "rejuv/waypoints", "rejuv/telemetry"},
                          Expect{"companion", "rejuv/waypoints", "rejuv/state", "rejuv/telemetry"}}) {
    SCOPED_TRACE(e.host);
    const fs::path enclave = store() / "enclaves" / e.host;
    for (const char* f : {"cert.pem", "key.pem", "identity_ca.cert.pem", "permissions_ca.cert.pem", "governance.p7s",
                          "permissions.p7s"}) {
      EXPECT_TRUE(fs::exists(enclave / f)) << f;
    }
    EXPECT_EQ(mode_of(enclave / "key.pem"), 0600U);
    const auto signed_text = rejuv::keys::verify_signed(store(), enclave / "permissions.p7s");
    ASSERT_TRUE(signed_text.has_value()) << signed_text.error();
    const std::string& p = *signed_text;
    EXPECT_NE(p.find("<subject_name>CN=" + e.host + "</subject_name>"), std::string::npos) << p;
    EXPECT_NE(p.find("<publish>\n          <topics>\n            <topic>" + e.publish + "</topic>\n          </topics>"),
              std::string::npos)
        << p;
    EXPECT_NE(p.find("<subscribe>\n          <topics>\n            <topic>" + e.subscribe + "</topic>\n          </topics>"),
              std::string::npos)
        << p;
    EXPECT_EQ(p.find(e.denied), std::string::npos) << p;  // read on its own host only: never on DDS
    EXPECT_NE(p.find("<default>DENY</default>"), std::string::npos);
    EXPECT_NE(p.find("<id>7</id>"), std::string::npos);
    const auto gov = rejuv::keys::verify_signed(store(), enclave / "governance.p7s");
    ASSERT_TRUE(gov.has_value()) << gov.error();
    EXPECT_NE(gov->find("<allow_unauthenticated_participants>false</allow_unauthenticated_participants>"),
              std::string::npos);
    EXPECT_NE(gov->find("<data_protection_kind>ENCRYPT</data_protection_kind>"), std::string::npos);
  }
}

TEST_F(Keys, Hosts_AlteredPermissions_FailVerification) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  ASSERT_EQ(rejuv({"keys", "hosts", store().string(), "--launch", kGraph}).exit_code, 0);
  const fs::path p7s = store() / "enclaves" / "companion" / "permissions.p7s";
  std::string text = slurp(p7s);
  const auto at = text.find("<topic>rejuv/waypoints</topic>");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 30, "<topic>rejuv/telemetry</topic>");  // a grant the policy never gave
  std::ofstream(p7s, std::ios::trunc) << text;
  const auto v = rejuv::keys::verify_signed(store(), p7s);
  EXPECT_FALSE(v.has_value());
}

TEST_F(Keys, Hosts_RerunKeepsIdentities) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  ASSERT_EQ(rejuv({"keys", "hosts", store().string(), "--launch", kGraph}).exit_code, 0);
  const std::string cert = slurp(store() / "enclaves" / "vehicle" / "cert.pem");
  ASSERT_EQ(rejuv({"keys", "hosts", store().string(), "--launch", kGraph}).exit_code, 0);
  EXPECT_EQ(slurp(store() / "enclaves" / "vehicle" / "cert.pem"), cert);
}

TEST_F(Keys, Init_DirIsAFile_Exit2) {
  std::ofstream(store()) << "not a folder";
  const auto r = rejuv({"keys", "init", store().string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(store().string() + ": exists and is not a directory"), std::string::npos) << r.err;
}

TEST_F(Keys, Hosts_WithoutCa_Exit2SaysToInit) {
  fs::create_directories(store());
  const auto r = rejuv({"keys", "hosts", store().string(), "--launch", kGraph});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no keystore CA (public/ca.cert.pem and private/ca.key.pem); make one with `rejuv keys init"),
            std::string::npos)
      << r.err;
}

TEST_F(Keys, Hosts_MissingDir_Exit2) {
  const auto r = rejuv({"keys", "hosts", (dir_ / "nowhere").string(), "--launch", kGraph});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no such keystore folder"), std::string::npos) << r.err;
}

TEST_F(Keys, Hosts_GraphWithoutHosts_Exit2) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  const auto r = rejuv({"keys", "hosts", store().string(), "--launch",
                        (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("the graph declares no `hosts { name address }`"), std::string::npos) << r.err;
}

TEST_F(Keys, Hosts_GraphThatFailsTheAudit_Exit1NothingWritten) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  // The policy's monitor reads the vehicle's state in SC as well: a crossing in the secure interval.
  std::string policy = slurp(kRepo / "tests" / "across_hosts" / "companion.policy.pbtxt");
  const std::string from = "object: \"state\" rights: \"R\" modes: [MC] }";
  policy.replace(policy.find(from), from.size(), "object: \"state\" rights: \"R\" modes: [MC, SC] }");
  std::ofstream(dir_ / "companion.policy.pbtxt") << policy;
  std::ofstream(dir_ / "companion.launch.pbtxt") << slurp(kGraph);
  const auto r = rejuv({"keys", "hosts", store().string(), "--launch", (dir_ / "companion.launch.pbtxt").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("violation [hosts:mc-only]"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(store() / "enclaves" / "companion" / "permissions.p7s"));
}

TEST_F(Keys, Check_MatchingKeystore_Exit0) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  ASSERT_EQ(rejuv({"keys", "hosts", store().string(), "--launch", kGraph}).exit_code, 0);
  const auto r = rejuv({"keys", "check", store().string(), "--launch", kGraph});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("keys: OK: "), std::string::npos) << r.out;
}

TEST_F(Keys, Check_PolicyChangedSinceTheKeystore_Exit1NamesTheStaleGrant) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  ASSERT_EQ(rejuv({"keys", "hosts", store().string(), "--launch", kGraph}).exit_code, 0);
  // The monitor is gone from the companion: the state no longer crosses, and the keystore still says it does.
  std::string policy = slurp(kRepo / "tests" / "across_hosts" / "companion.policy.pbtxt");
  std::string graph = slurp(kGraph);
  for (auto [text, from] : {std::pair{&policy, std::string("grants { service: \"monitor\" object: \"state\" rights: \"R\" modes: [MC] }\n")},
                            std::pair{&policy, std::string("services { name: \"monitor\" }\n")},
                            std::pair{&graph, std::string("services {\n  name: \"monitor\"\n  executable: \"o\"\n  host: \"companion\"\n  uses { object: \"state\" rights: \"R\" }\n}\n")}}) {
    const auto at = text->find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text->erase(at, from.size());
  }
  std::ofstream(dir_ / "companion.policy.pbtxt") << policy;
  std::ofstream(dir_ / "companion.launch.pbtxt") << graph;
  const auto r = rejuv({"keys", "check", store().string(), "--launch", (dir_ / "companion.launch.pbtxt").string()});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("enclave companion: permissions grant subscribing to rejuv/state; the policy grants nothing"),
            std::string::npos)
      << r.err;
  // With no reader on the companion, the vehicle's permission to publish the state is stale as well.
  EXPECT_NE(r.err.find("enclave vehicle: permissions grant publishing rejuv/state; the policy grants nothing"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("subscribing to rejuv/waypoints"), std::string::npos) << r.err;  // the waypoints still cross
}

// The companion graph with `dds { ros2_names: true }`, beside a copy of its policy; its path.
fs::path ros2_names_graph(const fs::path& dir) {
  fs::copy_file(kRepo / "tests" / "across_hosts" / "companion.policy.pbtxt", dir / "companion.policy.pbtxt",
                fs::copy_options::overwrite_existing);
  std::ofstream(dir / "companion.launch.pbtxt") << slurp(kGraph) << "dds { ros2_names: true }\n";
  return dir / "companion.launch.pbtxt";
}

TEST_F(Keys, Ros2NamesGraph_PermissionsGrantRtNames_AndTheKeystoreChecksClean) {
  const fs::path graph = ros2_names_graph(dir_);
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  const auto made = rejuv({"keys", "hosts", store().string(), "--launch", graph.string()});
  ASSERT_EQ(made.exit_code, 0) << made.err;
  EXPECT_NE(made.out.find("keys: enclave vehicle (domain 0): publish rt/state; subscribe rt/waypoints"), std::string::npos)
      << made.out;
  const std::string permissions = slurp(store() / "enclaves" / "companion" / "permissions.xml");
  EXPECT_NE(permissions.find("<topic>rt/state</topic>"), std::string::npos) << permissions;
  EXPECT_EQ(permissions.find("rejuv/"), std::string::npos) << permissions;
  const auto r = rejuv({"keys", "check", store().string(), "--launch", graph.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("keys: OK: "), std::string::npos) << r.out;
}

TEST_F(Keys, Check_KeystoreOfRejuvNames_RefusedForTheRos2NamesGraph) {
  ASSERT_EQ(rejuv({"keys", "init", store().string()}).exit_code, 0);
  ASSERT_EQ(rejuv({"keys", "hosts", store().string(), "--launch", kGraph}).exit_code, 0);  // rejuv/<topic>
  const auto r = rejuv({"keys", "check", store().string(), "--launch", ros2_names_graph(dir_).string()});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("enclave vehicle: permissions grant publishing rejuv/state; the policy grants rt/state"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("enclave companion: permissions grant subscribing to rejuv/state; the policy grants rt/state"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.out.find("keys: FAILED: "), std::string::npos) << r.out;
}

TEST_F(Keys, UnknownSubcommand_Exit2) {
  const auto r = rejuv({"keys", "rotate"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown subcommand 'rotate': expected init, hosts or check"), std::string::npos) << r.err;
}

}  // namespace
