// A service binary hostile from its first instruction reads the user's secrets (BOOT_READ_SECRETS,
// services/attacks/src/boot_attacks.cpp): at boot, before Ready, it reads the kernel's command line, which
// names the launch file, then the launch file, which names the MAVLink signing key's file, then the key.
// Flown as a user flies it — `rejuv run` on a launch file with a signing key file (mode 0600, the user's) —
// as root and as an unprivileged user (where the services once shared the kernel's uid and read the key), in
// lockstep and in real time. Judged by its effect: the key's bytes appear nowhere a service could have put
// them (the run's output and log, where the hostile binary prints what it read); the kernel refused the
// open at boot and said so, naming ext_link; the run completed (the kernel alive, exit 0).
//
// In the same flight, the ground side of the threat: a socket plays back frames signed with the right key but
// stamped 2015-01-01 (a recorded flight). Judged by the run's summary: every one refused as stale by the gate,
// none relayed to ext_link, and no telemetry sent to the replaying socket. No timing.
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

#include <google/protobuf/util/json_util.h>

#include <chrono>
#include <thread>

#include "rejuv/mavlink/messages.hpp"
#include "rejuv/sys/udp.hpp"
#include "rejuv_cli.hpp"
#include "summary.pb.h"

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

namespace mav = rejuv::mavlink;

// Frames played back from a recording: a ground station's heartbeats signed with the gate's key, stamped from
// 2015-01-01 on (the signing epoch), strictly increasing — correct but for their age.
struct Replayer {
  explicit Replayer(std::uint16_t kernel_port) : kernel(sys::UdpAddress::loopback(kernel_port)) {
    auto s = sys::UdpSocket::bind(sys::UdpAddress::loopback(0));
    EXPECT_TRUE(s.has_value());
    if (s) socket = std::move(*s);
  }
  // The next `n` frames of the recording.
  void send_recorded(std::size_t n) {
    const auto key = mav::SigningKey::from_hex(kKeyHex);
    ASSERT_TRUE(key.has_value());
    for (std::size_t i = 0; i < n; ++i) {
      at += mav::SigningClock::duration{100'000};  // a second apart in the recording
      ++sent;
      const mav::Message hb = mav::Heartbeat{.custom_mode = 0, .type = mav::kMavTypeGcs,
                                             .autopilot = mav::kMavAutopilotInvalid, .base_mode = 0,
                                             .system_status = mav::kMavStateActive, .mavlink_version = 3};
      const mav::Frame f = mav::encode(hb, mav::Envelope{.seq = static_cast<std::uint8_t>(i), .sysid = 255, .compid = 190},
                                       mav::Signer{.key = *key, .link_id = 1, .timestamp = at});
      ASSERT_TRUE(socket.send_to(f.view(), kernel).has_value());
    }
  }
  // Datagrams the vehicle sent to this socket (non-blocking).
  std::size_t heard() {
    std::array<std::byte, 2048> buf{};
    std::size_t n = 0;
    while (socket.receive(buf).has_value()) ++n;
    return n;
  }
  sys::UdpAddress kernel;
  sys::UdpSocket socket;
  mav::SigningTime at = mav::SigningClock::from_sys(std::chrono::sys_days{std::chrono::year{2015} / 1 / 1});
  std::uint64_t sent = 0;
};

// What the replaying socket did during a flight.
struct Playback {
  std::uint64_t sent = 0;   // recorded frames sent to the gate
  std::size_t heard = 0;    // datagrams the vehicle sent to the replaying socket
};

// `rejuv run` of the graph in `dir`, as the user `uid`/`gid` (the kernel's user: it owns dir and the key),
// with the recording played back to its gate for the whole flight (a frame every 5 ms: the gate drops what
// comes in the secure interval unread, so the recording must also arrive in MC windows).
CliOutcome fly_as(const fs::path& dir, uid_t uid, gid_t gid, bool realtime, Playback& playback) {
  std::vector<std::string> args{kRejuv.string(), "run", (dir / "hostile.launch.pbtxt").string(), "--duration", "4",
                                "--summary-json", (dir / "summary.json").string()};
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
  if (child > 0) {
    if (const std::uint16_t port = test_support::bound_gate_port(dir, child, std::chrono::seconds{60}); port != 0) {
      Replayer replayer(port);
      for (;;) {
        siginfo_t ended{};
        if (::waitid(P_PID, static_cast<id_t>(child), &ended, WEXITED | WNOHANG | WNOWAIT) == 0 && ended.si_pid == child) {
          break;
        }
        replayer.send_recorded(1);
        playback.heard += replayer.heard();
        std::this_thread::sleep_for(std::chrono::milliseconds{5});
      }
      int status = 0;
      if (::waitpid(child, &status, 0) == child) r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      playback.heard += replayer.heard();
      playback.sent = replayer.sent;
      r.out = slurp(dir / "stdout");
      r.err = slurp(dir / "stderr");
      return r;
    }
  }
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

TEST_P(BootSecrets, KeyNeverRead_OpenRefusedAndNamed_RecordingRefused_RunCompletes) {
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
  Playback playback;
  const CliOutcome r = fly_as(dir_, uid, gid, GetParam().realtime, playback);
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
  // The recording: refused as stale, every frame, before ext_link; nothing relayed; no telemetry to it.
  proto::RunSummary summary;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(dir_ / "summary.json"), &summary).ok()) << all;
  std::uint64_t stale = 0;
  for (const auto& refusal : summary.network().signing_refused_by_reason()) {
    if (refusal.reason() == "stale") stale = refusal.count();
  }
  const auto& net = summary.network();
  EXPECT_GT(playback.sent, 0U);
  // (what was sent while the kernel shut down is never read)
  EXPECT_LE(net.received(), playback.sent) << net.DebugString();
  EXPECT_GT(net.received(), 0U) << net.DebugString();
  EXPECT_GE(stale, 1U) << "no recorded frame reached the signing check (all in the secure interval?) "
                       << net.DebugString();
  EXPECT_EQ(stale + net.dropped_secure_interval(), net.received()) << net.DebugString();
  EXPECT_EQ(net.signing_refused(), stale) << net.DebugString();
  EXPECT_EQ(net.relayed(), 0U) << net.DebugString();
  EXPECT_EQ(net.link_valid(), 0U) << net.DebugString();
  EXPECT_EQ(playback.heard, 0U) << "the vehicle's telemetry went to the replaying socket";
  ::testing::Test::RecordProperty("recorded_frames_refused_stale", std::to_string(stale));
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
