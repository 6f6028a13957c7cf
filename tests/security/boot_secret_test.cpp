// A service binary hostile from its first instruction reads the user's secrets (issue 45, BOOT_READ_SECRETS,
// services/attacks/src/boot_attacks.cpp): at boot, before Ready, it reads the kernel's command line, which
// names the launch file, then the launch file, which names the MAVLink signing key's file, then the key.
// Flown as a user flies it — `rejuv run` on a launch file with a signing key file (mode 0600, the user's) —
// as root and as an unprivileged user (where the services once shared the kernel's uid and read the key), in
// lockstep and in real time. Judged by its effect: the key's bytes appear nowhere a service could have put
// them (the run's output and log, where the hostile binary prints what it read); the kernel refused the
// open at boot and said so, naming ext_link; the run completed (the kernel alive, exit 0). No timing.
#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rejuv_cli.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using test_support::CliOutcome;
using test_support::kRejuv;
using test_support::kRepo;
using test_support::slurp;

// 32 bytes as 64 hex digits: a key no other text of the run contains.
constexpr const char* kKeyHex = "5ec7e75ec7e75ec7e7a1b2c3d4e5f60718293a4b5c6d7e8f90a1b2c3d4e5f607";

struct Runner {
  bool unprivileged = false;
  bool realtime = false;
};

// The paper's square in `dir` with ext_link hostile from boot, the gate's key in key.hex next to it, a short
// alignment (the estimate converges in less; real time pays it in full).
void write_graph(const fs::path& dir) {
  std::string t = slurp(kRepo / "launch/quad_square_paper.launch.pbtxt");
  const auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = t.find(from);
    ASSERT_NE(at, std::string::npos) << "launch/quad_square_paper.launch.pbtxt has no '" << from << "'";
    t.replace(at, from.size(), to);
  };
  replace("policy: \"../policies/quad_sr.policy.pbtxt\"", "policy: \"" + (kRepo / "policies/quad_sr.policy.pbtxt").string() + "\"");
  replace("attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }",
          "attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }\n"
          "  attacks { kind: BOOT_READ_SECRETS service: \"ext_link\" }");
  replace("alignment_s: 20", "alignment_s: 8");
  t += "\nnetwork { bind_port: 0 signing_key_file: \"key.hex\" }\n";
  std::ofstream(dir / "hostile.launch.pbtxt") << t;
  std::ofstream(dir / "key.hex") << kKeyHex << "\n";
  fs::permissions(dir / "key.hex", fs::perms::owner_read | fs::perms::owner_write);
}

// `rejuv run` of the graph in `dir`, as the user `uid`/`gid` (the kernel's user: it owns dir and the key).
CliOutcome fly_as(const fs::path& dir, uid_t uid, gid_t gid, bool realtime) {
  std::vector<std::string> args{kRejuv.string(), "run", (dir / "hostile.launch.pbtxt").string(), "--duration", "4"};
  if (realtime) args.emplace_back("--realtime");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string out = (dir / "stdout").string();
  const std::string err = (dir / "stderr").string();
  const bool drop = uid != ::geteuid();
  const pid_t child = ::fork();
  if (child == 0) {
    if (drop && (::setgroups(0, nullptr) != 0 || ::setresgid(gid, gid, gid) != 0 || ::setresuid(uid, uid, uid) != 0)) {
      ::_exit(90);
    }
    const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (o < 0 || e < 0 || ::dup2(o, 1) < 0 || ::dup2(e, 2) < 0) ::_exit(91);
    ::execve(argv[0], argv.data(), environ);
    ::_exit(92);
  }
  CliOutcome r;
  int status = 0;
  if (child > 0 && ::waitpid(child, &status, 0) == child) {
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  r.out = slurp(dir / "stdout");
  r.err = slurp(dir / "stderr");
  return r;
}

class BootSecrets : public ::testing::TestWithParam<Runner> {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root (to fly as root and as an unprivileged user)";
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::ranges::replace(name, '/', '_');  // a parameterised test's name has a '/'
    dir_ = fs::temp_directory_path() / ("rejuv_boot_secrets_" + std::to_string(::getpid()) + "_" + name);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

TEST_P(BootSecrets, KeyNeverRead_OpenRefusedAndNamed_RunCompletes) {
  uid_t uid = 0;
  gid_t gid = 0;
  if (GetParam().unprivileged) {
    const passwd* nobody = ::getpwnam("nobody");
    ASSERT_NE(nobody, nullptr);
    uid = nobody->pw_uid;
    gid = nobody->pw_gid;
    for (fs::path p = fs::path(REJUV_BINARY_DIR); !p.empty() && p != p.root_path(); p = p.parent_path()) {
      if ((fs::status(p).permissions() & fs::perms::others_exec) == fs::perms::none) {
        GTEST_SKIP() << p << " is not searchable by other users";
      }
    }
  }
  ASSERT_NO_FATAL_FAILURE(write_graph(dir_));
  // The kernel's user owns the folder, the launch file and the key (mode 0600): the key is the user's secret.
  for (const fs::path& p : {dir_, dir_ / "hostile.launch.pbtxt", dir_ / "key.hex"}) {
    ASSERT_EQ(::chown(p.c_str(), uid, gid), 0) << p;
  }
  ::chmod(dir_.c_str(), 0700);
  const CliOutcome r = fly_as(dir_, uid, gid, GetParam().realtime);
  const std::string all = r.out + r.err;
  ASSERT_NE(r.exit_code, 90) << "could not become the unprivileged user";
  EXPECT_EQ(r.exit_code, 0) << all;
  // The hostile binary prints whatever it read: the key is not in it (nor its first half, in any line).
  EXPECT_EQ(all.find(kKeyHex), std::string::npos) << "the signing key was read by a service";
  EXPECT_EQ(all.find(std::string(kKeyHex).substr(0, 24)), std::string::npos) << "part of the key was read";
  // What it tried, and that the kernel refused it at boot, naming the service and the path.
  EXPECT_NE(all.find("attack BOOT_READ_SECRETS: kernel cmdline unread"), std::string::npos) << all;
  EXPECT_NE(all.find("'ext_link' at boot: openat of /proc/"), std::string::npos) << all;
  EXPECT_NE(all.find("outside what a start-up reads"), std::string::npos) << all;
  ::testing::Test::RecordProperty("output_bytes", std::to_string(all.size()));
}

INSTANTIATE_TEST_SUITE_P(Containment, BootSecrets,
                         ::testing::Values(Runner{false, false}, Runner{false, true}, Runner{true, false},
                                           Runner{true, true}),
                         [](const ::testing::TestParamInfo<Runner>& i) {
                           return std::string(i.param.unprivileged ? "WithoutRoot" : "Root") +
                                  (i.param.realtime ? "_RealTime" : "_Lockstep");
                         });

}  // namespace
}  // namespace rejuv::testing
