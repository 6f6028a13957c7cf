// The network gate (DESIGN §2, §3; docs/protocol.md "Network gate") with the real ext_link, in lockstep
// driven by the test: the test is the ground station on a UDP socket; a test service (`vehicle`,
// tests/multiproc/services/net_test_service.cpp) switches modes when the test injects a mode_command.
// Network traffic sent during the secure interval never reaches ext_link; in MC it does; oversize and
// garbage datagrams are refused without harm.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "graph_fixture.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/services/ext_link/link_protocol.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv::testing {
namespace {

using kernel::Kernel;

constexpr std::string_view kNetLaunch = R"(
name: "net_gate"
policy: "net.policy.pbtxt"
clock: LOCKSTEP
seed: 1
services {
  name: "ext_link"
  executable: "rejuv_ext_link"
  params { name: "telemetry_period_s" number: 0.02 }
  uses { object: "ext_net" rights: "RW" }
  uses { object: "vehicle_state" rights: "R" }
  uses { object: "setpoint" rights: "R" }
  uses { object: "sr_mode" rights: "R" }
  uses { object: "security_event" rights: "R" }
  uses { object: "mission_upload" rights: "W" }
}
services {
  name: "vehicle"
  executable: "rejuv_net_test_service"
  uses { object: "vehicle_state" rights: "W" }
  uses { object: "setpoint" rights: "W" }
  uses { object: "mission_upload" rights: "R" }
  uses { object: "mode_command" rights: "R" }
  uses { object: "sr_mode_control" rights: "W" }
  uses { object: "ext_net" rights: "W" }
}
mission { waypoints { north_m: 0 east_m: 0 down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 600 }
)";

link::MissionUpload upload_of(std::uint32_t count) {
  link::MissionUpload up;
  up.count = count;
  up.acceptance_radius_m = 0.2;
  for (std::uint32_t i = 0; i < count; ++i) {
    up.waypoints[i] = link::UploadWaypoint{.north_m = 1.0 * i, .east_m = 0.5, .down_m = -3, .yaw_rad = 0};
  }
  return up;
}

// The ground station: a UDP socket that talks to the kernel's gate.
class Ground {
 public:
  explicit Ground(std::uint16_t kernel_port) : kernel_(sys::UdpAddress::loopback(kernel_port)) {
    auto s = sys::UdpSocket::bind(sys::UdpAddress::loopback(0));
    EXPECT_TRUE(s.has_value());
    if (s) socket_ = std::move(*s);
  }
  void send(std::span<const std::byte> bytes) { ASSERT_TRUE(socket_.send_to(bytes, kernel_).has_value()); }
  void send(const link::Message& m) { send(link::encode(m).view()); }
  // Everything the vehicle sent so far (non-blocking), decoded; undecodable ones counted in `raw`.
  void collect() {
    std::array<std::byte, 2048> buf{};
    for (;;) {
      auto r = socket_.receive(buf);
      if (!r) {
        EXPECT_EQ(r.error().error, EAGAIN);
        return;
      }
      auto m = link::decode(std::span<const std::byte>(buf.data(), r->size), link::Direction::ToGround);
      if (m) {
        received.push_back(*m);
      } else {
        raw.emplace_back(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r->size));
      }
    }
  }
  template <class T>
  [[nodiscard]] std::vector<T> all() const {
    std::vector<T> out;
    for (const link::Message& m : received) {
      if (const auto* x = std::get_if<T>(&m.body)) out.push_back(*x);
    }
    return out;
  }
  void clear() {
    received.clear();
    raw.clear();
  }
  std::vector<link::Message> received;
  std::vector<std::vector<std::byte>> raw;

 private:
  sys::UdpAddress kernel_;
  sys::UdpSocket socket_;
};

class NetGate : public ::testing::Test {
 protected:
  void SetUp() override {
    before_ = Resources::now();
    auto graph = launch::parse_launch(kNetLaunch, kGraphs / "net.launch.pbtxt");
    ASSERT_TRUE(graph.has_value()) << graph.error().to_string();
    auto options = test_options();
    options.network_port = 0;  // ephemeral: no clash with a `rejuv run` on this host
    auto k = Kernel::create(std::move(*graph), std::move(options), &recorder_);
    ASSERT_TRUE(k.has_value()) << k.error().to_string();
    kernel_ = std::move(*k);
    auto booted = kernel_->boot();
    ASSERT_TRUE(booted.has_value()) << booted.error().to_string();
    ASSERT_TRUE(kernel_->network_port().has_value());
    ground_.emplace(*kernel_->network_port());
    step(5);
    ASSERT_EQ(kernel_->mode(), SrMode::MC);
  }
  void TearDown() override {
    if (kernel_) {
      kernel_->shutdown();
      for (const char* name : {"ext_link", "vehicle"}) {
        const auto st = kernel_->stats(*kernel_->find_service(name));
        ASSERT_TRUE(st.exit.has_value()) << name;
        EXPECT_TRUE(st.exit->success()) << name << ": " << st.exit->to_string();  // never crashed
      }
      kernel_.reset();
    }
    ground_.reset();
    const Resources after = Resources::now();
    EXPECT_EQ(after.children, before_.children);
    EXPECT_EQ(after.fds, before_.fds);
  }

  void step(int n) {
    step_n(*kernel_, n);
    ASSERT_FALSE(kernel_->stop_reason().has_value()) << kernel_->stop_detail();
  }
  // Steps until `done` (the kernel has read what the test sent: loopback delivery is not promised to be
  // instantaneous), at most `max_steps`.
  template <class F>
  void step_until(F done, int max_steps = 500) {
    for (int i = 0; i < max_steps && !done(); ++i) step(1);
    ASSERT_TRUE(done()) << "not reached within " << max_steps << " steps";
  }
  void set_mode(SrMode mode) {
    rejuv_msg_SensorBaro command{};  // graphs/net.policy.pbtxt: altitude_m = the SrMode index
    command.altitude_m = static_cast<double>(index_of(mode));
    ASSERT_TRUE(kernel_->inject("mode_command", std::as_bytes(std::span(&command, 1))).has_value());
    step_until([&] { return kernel_->mode() == mode; }, 50);
  }
  [[nodiscard]] std::size_t uploads_seen() const { return recorder_.on("mission_upload").size(); }
  [[nodiscard]] kernel::ServiceStats stats(std::string_view name) const {
    return kernel_->stats(*kernel_->find_service(name));
  }

  Resources before_{};
  Recorder recorder_;
  std::unique_ptr<Kernel> kernel_;
  std::optional<Ground> ground_;
};

TEST_F(NetGate, DatagramsDuringSecureInterval_NeverReachExtLink) {
  set_mode(SrMode::SC);
  // Given the secure interval, when the ground says Hello and uploads (three times) ...
  ground_->send({.sequence = 1, .body = link::Hello{}});
  for (int i = 0; i < 3; ++i) ground_->send({.sequence = 2, .body = upload_of(4)});
  step_until([&] { return kernel_->net_stats().received == 4; });
  // ... then every datagram is dropped and counted, and nothing reaches ext_link.
  EXPECT_EQ(kernel_->net_stats().dropped_secure_interval, 4U);
  EXPECT_EQ(kernel_->net_stats().relayed, 0U);
  step(50);
  EXPECT_EQ(uploads_seen(), 0U);
  // Back in MC: dropped means dropped, not delayed. ext_link never heard the Hello, so it sends nothing.
  set_mode(SrMode::MC);
  step(50);
  ground_->collect();
  EXPECT_EQ(uploads_seen(), 0U);
  EXPECT_TRUE(ground_->all<link::Telemetry>().empty());
  EXPECT_TRUE(ground_->all<link::MissionAck>().empty());
  EXPECT_EQ(kernel_->net_stats().relayed, 0U);
  EXPECT_EQ(stats("ext_link").denials, 0U);  // an honest ext_link tried nothing in the SEI
}

TEST_F(NetGate, UploadInMissionControl_ReachesCommanderAndIsAcknowledged) {
  ground_->send({.sequence = 77, .body = upload_of(3)});
  step_until([&] { return kernel_->net_stats().relayed == 1; });
  step_until([&] {
    ground_->collect();
    return !ground_->all<link::MissionAck>().empty();
  });
  EXPECT_EQ(ground_->all<link::MissionAck>().front().upload_sequence, 77U);
  ASSERT_EQ(uploads_seen(), 1U);
  const auto upload = Recorder::as<rejuv_msg_MissionWaypoints>(*recorder_.on("mission_upload").front());
  EXPECT_EQ(upload.count, 3U);
  EXPECT_DOUBLE_EQ(upload.waypoints[2].p_N_m[0], 2.0);
  EXPECT_DOUBLE_EQ(upload.acceptance_radius_m, 0.2);
  // The ground is known now: telemetry flows in MC, with the vehicle's state.
  step_until([&] {
    ground_->collect();
    return !ground_->all<link::Telemetry>().empty();
  });
  const link::Telemetry t = ground_->all<link::Telemetry>().back();
  EXPECT_EQ(t.sr_mode, 0);
  EXPECT_DOUBLE_EQ(t.p_N_m[2], -3.0);
  EXPECT_EQ(t.uploads_forwarded, 1U);
  EXPECT_GE(kernel_->net_stats().sent, 2U);  // the ack and a telemetry message
  EXPECT_EQ(kernel_->net_stats().send_refused, 0U);
}

TEST_F(NetGate, RetransmittedUpload_AcknowledgedAgainPublishedOnce) {
  for (int i = 0; i < 3; ++i) {
    ground_->send({.sequence = 5, .body = upload_of(2)});
    const std::uint64_t want = static_cast<std::uint64_t>(i) + 1;
    step_until([&] { return kernel_->net_stats().relayed == want; });
  }
  step_until([&] {
    ground_->collect();
    return ground_->all<link::MissionAck>().size() == 3;
  });
  EXPECT_EQ(uploads_seen(), 1U);
}

TEST_F(NetGate, SecureInterval_StopsTelemetryAndRefusesSends) {
  ground_->send({.sequence = 1, .body = link::Hello{}});
  step_until([&] {
    ground_->collect();
    return !ground_->all<link::Telemetry>().empty();
  });
  // Entering SC: the vehicle's rogue NetSend (it does not ask the SDK first) is denied by the kernel.
  set_mode(SrMode::SC);
  EXPECT_GE(kernel_->net_stats().send_refused, 1U);
  EXPECT_GE(stats("vehicle").denials, 1U);
  step(10);
  ground_->collect();
  ground_->clear();
  step(100);  // 0.4 s: 20 telemetry periods
  ground_->collect();
  EXPECT_TRUE(ground_->received.empty());
  EXPECT_TRUE(ground_->raw.empty());  // nor the rogue's datagram
  EXPECT_EQ(stats("ext_link").denials, 0U);  // ext_link is honest: it did not try
  // Back in MC: telemetry resumes (the ground is still known), with no new Hello.
  set_mode(SrMode::MC);
  step_until([&] {
    ground_->collect();
    return !ground_->all<link::Telemetry>().empty();
  });
}

TEST_F(NetGate, OversizeAndGarbageDatagrams_RefusedWithoutHarm) {
  const std::vector<std::byte> huge(wire::kMaxDatagramBytes + 1, std::byte{0x42});
  ground_->send(huge);
  ground_->send(std::span<const std::byte>{});
  // Garbage the kernel relays (it does not interpret the bytes) and ext_link refuses.
  std::vector<std::vector<std::byte>> garbage;
  garbage.push_back(std::vector<std::byte>(7, std::byte{0xFF}));
  const link::Datagram good = link::encode({.sequence = 9, .body = upload_of(4)});
  link::Datagram bad_crc = good;
  bad_crc.bytes[40] ^= std::byte{1};
  garbage.emplace_back(bad_crc.view().begin(), bad_crc.view().end());
  garbage.emplace_back(good.view().begin(), good.view().begin() + 40);  // truncated
  const link::Datagram telemetry = link::encode({.sequence = 3, .body = link::Telemetry{}});
  garbage.emplace_back(telemetry.view().begin(), telemetry.view().end());  // a vehicle → ground type
  for (const auto& g : garbage) ground_->send(g);
  step_until([&] { return kernel_->net_stats().received == 2 + garbage.size(); });
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_EQ(st.dropped_oversize, 1U);
  EXPECT_EQ(st.dropped_empty, 1U);
  EXPECT_EQ(st.relayed, garbage.size());
  step(20);
  EXPECT_EQ(uploads_seen(), 0U);
  ground_->collect();
  // No answer to garbage (telemetry may come: the gate relayed it, so it knows where the ground is).
  EXPECT_TRUE(ground_->all<link::MissionAck>().empty());
  EXPECT_TRUE(ground_->raw.empty());
  // ext_link is unharmed: a good upload still goes through, and its telemetry counts the refusals.
  ground_->send(good.view());
  step_until([&] {
    ground_->collect();
    return !ground_->all<link::MissionAck>().empty() && !ground_->all<link::Telemetry>().empty();
  });
  EXPECT_EQ(uploads_seen(), 1U);
  EXPECT_EQ(ground_->all<link::Telemetry>().back().link_refused, garbage.size());
  EXPECT_TRUE(stats("ext_link").alive);
  EXPECT_EQ(stats("ext_link").bad_frames, 0U);
}

// Item 5 of the fault report: any relayed datagram used to redirect telemetry to its sender. Now only a
// message ext_link judges valid names the ground station; garbage from elsewhere is refused, counted by
// reason in the kernel (for the run summary) and steers nothing.
TEST_F(NetGate, GarbageFromAnotherSender_DoesNotRedirectTelemetry) {
  ground_->send({.sequence = 1, .body = link::Hello{}});
  step_until([&] {
    ground_->collect();
    return !ground_->all<link::Telemetry>().empty();
  });
  Ground stranger(*kernel_->network_port());
  std::vector<std::byte> garbage(20, std::byte{0x5A});  // no "RJLK": BadMagic
  stranger.send(garbage);
  step_until([&] { return kernel_->net_stats().judged_refused == 1; });
  ground_->clear();
  step(50);  // 0.2 s: 10 telemetry periods
  ground_->collect();
  stranger.collect();
  EXPECT_TRUE(stranger.received.empty() && stranger.raw.empty()) << "telemetry followed the garbage";
  EXPECT_FALSE(ground_->all<link::Telemetry>().empty()) << "telemetry still goes to the ground station";
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_EQ(st.judged_valid, 1U);
  EXPECT_EQ(st.refused_by_reason[1 + static_cast<std::size_t>(link::DecodeError::BadMagic)], 1U);
}

// Issue 18 item 5: a well-formed upload that commander would refuse (here 12 m east of home, outside the 10 m
// geofence) is answered with a negative acknowledgement naming the reason and the waypoint; nothing reaches
// commander's topic. It used to be acknowledged as forwarded (and then dropped by commander, silently).
TEST_F(NetGate, UploadOutsideTheGeofence_NegativelyAcknowledgedNotPublished) {
  link::MissionUpload far = upload_of(3);
  far.waypoints[1].east_m = 12;
  for (int i = 0; i < 2; ++i) {  // the second is a retransmission: refused again
    ground_->send({.sequence = 31, .body = far});
    const std::uint64_t want = static_cast<std::uint64_t>(i) + 1;
    step_until([&] { return kernel_->net_stats().relayed == want; });
  }
  step_until([&] {
    ground_->collect();
    return ground_->all<link::MissionAck>().size() == 2;
  });
  for (const link::MissionAck& ack : ground_->all<link::MissionAck>()) {
    EXPECT_EQ(ack.upload_sequence, 31U);
    EXPECT_EQ(ack.status, link::AckStatus::Refused);
    EXPECT_EQ(ack.reason, link::RefusalReason::OutsideGeofence);
    EXPECT_EQ(ack.waypoint, 1U);
  }
  step(20);
  EXPECT_EQ(uploads_seen(), 0U);
  // A valid message: the sender is the ground station, and the verdict the kernel counts is "valid".
  EXPECT_EQ(kernel_->net_stats().judged_valid, 2U);
  EXPECT_EQ(kernel_->net_stats().judged_refused, 0U);
}

// `rejuv gcs` as a user runs it (the real binary, in real time) against the real gate and ext_link (stepped
// by the test until it exits): its exit code and what it prints.
struct GcsOutcome {
  int exit_code = -1;
  std::string out;
};

class NetGateGcs : public NetGate {
 protected:
  GcsOutcome gcs(const std::string& waypoints) {
    const std::filesystem::path rejuv = std::filesystem::path(REJUV_BINARY_DIR) / "tools" / "rejuv" / "rejuv";
    const std::filesystem::path out =
        std::filesystem::temp_directory_path() / ("rejuv_net_gate_gcs_" + std::to_string(::getpid()));
    std::vector<std::string> args{rejuv.string(), "gcs", "--port", std::to_string(*kernel_->network_port()),
                                  "--waypoints", waypoints, "--timeout", "60"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    pid_t pid = -1;
    GcsOutcome r;
    const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    EXPECT_EQ(spawned, 0) << rejuv;
    if (spawned != 0) return r;
    // gcs gives up by itself after --timeout; the cap only keeps a broken test from spinning forever.
    int status = 0;
    bool exited = false;
    for (int i = 0; i < 2'000'000 && !exited; ++i) {
      step_n(*kernel_, 1);
      exited = ::waitpid(pid, &status, WNOHANG) == pid;
    }
    if (!exited) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      ADD_FAILURE() << "rejuv gcs did not exit";
    } else if (WIFEXITED(status)) {
      r.exit_code = WEXITSTATUS(status);
    }
    std::ifstream in(out);
    std::ostringstream text;
    text << in.rdbuf();
    r.out = text.str();
    std::error_code ec;
    std::filesystem::remove(out, ec);
    return r;
  }
};

TEST_F(NetGateGcs, RefusedUpload_Exit1PrintsTheReason) {
  const GcsOutcome r = gcs("1,0.5,-3;0,12,-3");  // the second waypoint 12 m east of home
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("refused"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("outside the geofence (waypoint 2"), std::string::npos) << r.out;
  EXPECT_EQ(uploads_seen(), 0U);
}

TEST_F(NetGateGcs, ValidUpload_Exit0) {
  const GcsOutcome r = gcs("1,0.5,-3;0,2,-3");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("upload acknowledged"), std::string::npos) << r.out;
  EXPECT_EQ(uploads_seen(), 1U);
}

}  // namespace
}  // namespace rejuv::testing
