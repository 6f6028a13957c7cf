// The network gate (docs/design.md §2, §3; docs/protocol.md "Network gate") with the real ext_link, in lockstep
// driven by the test: the test is the ground station on a UDP socket; a test service (`vehicle`,
// tests/multiproc/services/net_test_service.cpp) switches modes when the test injects a mode_command.
// Network traffic sent during the secure interval never reaches ext_link; in MC it does (MAVLink 2, the mission
// upload protocol); oversize and garbage datagrams are refused without harm.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "graph_fixture.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/mavlink/mission.hpp"
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

namespace mav = rejuv::mavlink;

std::vector<mav::LocalWaypoint> waypoints_of(std::uint32_t count) {
  std::vector<mav::LocalWaypoint> out;
  for (std::uint32_t i = 0; i < count; ++i) out.push_back({.north_m = 1.0 * i, .east_m = 0.5, .down_m = -3, .yaw_rad = 0});
  return out;
}

mav::Message ground_heartbeat() {
  return mav::Heartbeat{.custom_mode = 0, .type = mav::kMavTypeGcs, .autopilot = mav::kMavAutopilotInvalid,
                        .base_mode = 0, .system_status = mav::kMavStateActive, .mavlink_version = 3};
}

// The ground station: a UDP socket that talks MAVLink 2 to the kernel's gate (optionally signing).
class Ground {
 public:
  explicit Ground(std::uint16_t kernel_port) : kernel_(sys::UdpAddress::loopback(kernel_port)) {
    auto s = sys::UdpSocket::bind(sys::UdpAddress::loopback(0));
    EXPECT_TRUE(s.has_value());
    if (s) socket_ = std::move(*s);
  }
  void send(std::span<const std::byte> bytes) { ASSERT_TRUE(socket_.send_to(bytes, kernel_).has_value()); }
  void send(const mav::Message& m) { send(frame(m).view()); }
  [[nodiscard]] mav::Frame frame(const mav::Message& m) {
    std::optional<mav::Signer> signer;
    if (key) {
      // Stamped as a ground station does, from the wall clock (the gate refuses a timestamp more than a minute
      // behind its own), strictly increasing; or, replaying a recording, from where the recording started.
      constexpr mav::SigningClock::duration kTick{1};
      timestamp = recorded_at ? std::max(*recorded_at, timestamp + kTick) : std::max(mav::SigningClock::now(), timestamp + kTick);
      signer = mav::Signer{.key = *key, .link_id = 1, .timestamp = timestamp};
    }
    return mav::encode(m, mav::Envelope{.seq = seq_++, .sysid = 255, .compid = 190}, signer);
  }
  // Everything the vehicle sent so far (non-blocking), decoded; undecodable ones kept in `raw`.
  void collect() {
    std::array<std::byte, 2048> buf{};
    for (;;) {
      auto r = socket_.receive(buf);
      if (!r) {
        EXPECT_EQ(r.error().error, EAGAIN);
        return;
      }
      auto p = mav::decode(std::span<const std::byte>(buf.data(), r->size));
      if (p) {
        received.push_back(p->message);
      } else {
        raw.emplace_back(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r->size));
      }
    }
  }
  // What arrived since the last call.
  [[nodiscard]] std::vector<mav::Message> take_new() {
    collect();
    std::vector<mav::Message> out(received.begin() + static_cast<std::ptrdiff_t>(taken_), received.end());
    taken_ = received.size();
    return out;
  }
  template <class T>
  [[nodiscard]] std::vector<T> all() const {
    std::vector<T> out;
    for (const mav::Message& m : received) {
      if (const auto* x = std::get_if<T>(&m)) out.push_back(*x);
    }
    return out;
  }
  void clear() {
    received.clear();
    raw.clear();
    taken_ = 0;
  }
  std::vector<mav::Message> received;
  std::vector<std::vector<std::byte>> raw;
  std::optional<mav::SigningKey> key;
  mav::SigningTime timestamp{};                   // the last one stamped
  std::optional<mav::SigningTime> recorded_at{};  // set: frames of a recording made then (signed with the key)

 private:
  sys::UdpAddress kernel_;
  sys::UdpSocket socket_;
  std::uint8_t seq_ = 0;
  std::size_t taken_ = 0;
};

class NetGate : public ::testing::Test {
 protected:
  [[nodiscard]] virtual std::string launch_text() const { return std::string(kNetLaunch); }
  void SetUp() override {
    before_ = Resources::now();
    auto graph = launch::parse_launch(launch_text(), kGraphs / "net.launch.pbtxt");
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
  // Runs an upload as a ground station does: sends, steps the kernel until the vehicle answers and answers
  // it, retransmitting the last message every 50 steps (200 ms) without an answer; at most `max_steps`.
  mav::MissionUploader::Status run_upload(mav::MissionUploader& up, int max_steps = 3000) {
    ground_->send(up.start());
    int quiet = 0;
    for (int i = 0; i < max_steps && up.status() == mav::MissionUploader::Status::InProgress; ++i) {
      step_n(*kernel_, 1);
      bool answered = false;
      for (const mav::Message& m : ground_->take_new()) {
        if (auto reply = up.on_message(m)) ground_->send(*reply);
        answered = answered || std::holds_alternative<mav::MissionRequestInt>(m) || std::holds_alternative<mav::MissionAck>(m);
      }
      quiet = answered ? 0 : quiet + 1;
      if (quiet == 50 && up.status() == mav::MissionUploader::Status::InProgress) {
        ground_->send(up.last_sent());
        quiet = 0;
      }
    }
    return up.status();
  }
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
  // Given the secure interval, when the ground sends a HEARTBEAT and starts an upload (three times) ...
  ground_->send(ground_heartbeat());
  for (int i = 0; i < 3; ++i) ground_->send(mav::MissionCount{.count = 4, .target_system = 1, .target_component = 1, .mission_type = 0, .opaque_id = 0});
  step_until([&] { return kernel_->net_stats().received == 4; });
  // ... then every datagram is dropped and counted, and nothing reaches ext_link.
  EXPECT_EQ(kernel_->net_stats().dropped_secure_interval, 4U);
  EXPECT_EQ(kernel_->net_stats().relayed, 0U);
  step(50);
  EXPECT_EQ(uploads_seen(), 0U);
  // Back in MC: dropped means dropped, not delayed. The ground station is unknown, so nothing is sent.
  set_mode(SrMode::MC);
  step(50);
  ground_->collect();
  EXPECT_EQ(uploads_seen(), 0U);
  EXPECT_TRUE(ground_->received.empty());
  EXPECT_EQ(kernel_->net_stats().relayed, 0U);
  EXPECT_EQ(stats("ext_link").denials, 0U);  // an honest ext_link tried nothing in the SEI
}

TEST_F(NetGate, UploadInMissionControl_ReachesCommanderAndIsAcknowledged) {
  mav::MissionUploader up(waypoints_of(3), 0.2);
  ASSERT_EQ(run_upload(up), mav::MissionUploader::Status::Accepted);
  ASSERT_EQ(uploads_seen(), 1U);
  const auto upload = Recorder::as<rejuv_msg_MissionWaypoints>(*recorder_.on("mission_upload").front());
  EXPECT_EQ(upload.count, 3U);
  EXPECT_NEAR(upload.waypoints[2].p_N_m[0], 2.0, 1e-4);
  EXPECT_NEAR(upload.acceptance_radius_m, 0.2, 1e-6);
  // The ground is known now: telemetry flows in MC, with the vehicle's state.
  step_until([&] {
    ground_->collect();
    return !ground_->all<mav::LocalPositionNed>().empty() && !ground_->all<mav::Heartbeat>().empty();
  });
  EXPECT_FLOAT_EQ(ground_->all<mav::LocalPositionNed>().back().z, -3.0F);
  const mav::Heartbeat hb = ground_->all<mav::Heartbeat>().back();
  EXPECT_EQ(hb.type, mav::kMavTypeQuadrotor);
  EXPECT_EQ(hb.custom_mode & 0xFFU, 0U) << "MC";
  EXPECT_GE(kernel_->net_stats().sent, 5U);  // the requests, the ack and telemetry
  EXPECT_EQ(kernel_->net_stats().send_refused, 0U);
}

TEST_F(NetGate, UploadStartedInTheSecureInterval_CompletesInMc) {
  // The ground station starts in SC: everything it sends is dropped; it retransmits; in MC the upload goes on.
  set_mode(SrMode::SC);
  mav::MissionUploader up(waypoints_of(2), 0.2);
  ground_->send(up.start());
  step_until([&] { return kernel_->net_stats().dropped_secure_interval == 1; });
  set_mode(SrMode::MC);
  ASSERT_EQ(run_upload(up), mav::MissionUploader::Status::Accepted);
  EXPECT_EQ(uploads_seen(), 1U);
}

TEST_F(NetGate, RepeatedUpload_AcknowledgedAgainPublishedOnce) {
  for (int i = 0; i < 3; ++i) {
    mav::MissionUploader up(waypoints_of(2), 0.2);
    ASSERT_EQ(run_upload(up), mav::MissionUploader::Status::Accepted) << i;
  }
  EXPECT_EQ(uploads_seen(), 1U);
}

TEST_F(NetGate, SecureInterval_StopsTelemetryAndRefusesSends) {
  ground_->send(ground_heartbeat());
  step_until([&] {
    ground_->collect();
    return !ground_->all<mav::LocalPositionNed>().empty();
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
  // Back in MC: telemetry resumes (the ground is still known), and the modes seen meanwhile are reported.
  set_mode(SrMode::MC);
  step_until([&] {
    ground_->collect();
    return !ground_->all<mav::LocalPositionNed>().empty() && !ground_->all<mav::StatusText>().empty();
  });
  bool saw_sc = false;
  for (const mav::StatusText& t : ground_->all<mav::StatusText>()) saw_sc = saw_sc || mav::text_of(t) == "SR mode SC";
  EXPECT_TRUE(saw_sc);
}

TEST_F(NetGate, OversizeAndGarbageDatagrams_RefusedWithoutHarm) {
  const std::vector<std::byte> huge(wire::kMaxDatagramBytes + 1, std::byte{0x42});
  ground_->send(huge);
  ground_->send(std::span<const std::byte>{});
  // Garbage the kernel relays (it does not interpret the bytes) and ext_link refuses.
  std::vector<std::vector<std::byte>> garbage;
  garbage.push_back(std::vector<std::byte>(7, std::byte{0xFF}));
  const mav::Frame good = ground_->frame(mav::local_item(waypoints_of(2)[1], 1, 0.2, 1, 1));
  mav::Frame bad_crc = good;
  bad_crc.bytes[20] ^= std::byte{1};
  garbage.emplace_back(bad_crc.view().begin(), bad_crc.view().end());
  garbage.emplace_back(good.view().begin(), good.view().begin() + 20);  // truncated
  mav::Frame unknown = good;
  unknown.bytes[7] = std::byte{0x99};  // a message id this vehicle does not know
  garbage.emplace_back(unknown.view().begin(), unknown.view().end());
  for (const auto& g : garbage) ground_->send(g);
  step_until([&] { return kernel_->net_stats().received == 2 + garbage.size(); });
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_EQ(st.dropped_oversize, 1U);
  EXPECT_EQ(st.dropped_empty, 1U);
  EXPECT_EQ(st.relayed, garbage.size());
  step(20);
  EXPECT_EQ(uploads_seen(), 0U);
  ground_->collect();
  EXPECT_TRUE(ground_->received.empty()) << "no answer to garbage, and no ground station known";
  EXPECT_TRUE(ground_->raw.empty());
  EXPECT_EQ(kernel_->net_stats().judged_refused, garbage.size());
  // ext_link is unharmed: an upload still goes through.
  mav::MissionUploader up(waypoints_of(2), 0.2);
  ASSERT_EQ(run_upload(up), mav::MissionUploader::Status::Accepted);
  EXPECT_EQ(uploads_seen(), 1U);
  EXPECT_TRUE(stats("ext_link").alive);
  EXPECT_EQ(stats("ext_link").bad_frames, 0U);
}

// Only a message ext_link judges valid names the ground station; garbage from elsewhere is refused, counted by
// reason in the kernel (for the run summary) and steers nothing.
TEST_F(NetGate, GarbageFromAnotherSender_DoesNotRedirectTelemetry) {
  ground_->send(ground_heartbeat());
  step_until([&] {
    ground_->collect();
    return !ground_->all<mav::LocalPositionNed>().empty();
  });
  Ground stranger(*kernel_->network_port());
  std::vector<std::byte> garbage(20, std::byte{0x5A});  // no 0xFD: BadStart
  stranger.send(garbage);
  step_until([&] { return kernel_->net_stats().judged_refused == 1; });
  ground_->clear();
  step(50);  // 0.2 s: 10 telemetry periods
  ground_->collect();
  stranger.collect();
  EXPECT_TRUE(stranger.received.empty() && stranger.raw.empty()) << "telemetry followed the garbage";
  EXPECT_FALSE(ground_->all<mav::LocalPositionNed>().empty()) << "telemetry still goes to the ground station";
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_EQ(st.judged_valid, 1U);
  EXPECT_EQ(st.refused_by_reason[1 + static_cast<std::size_t>(mav::DecodeError::BadStart)], 1U);
}

// A well-formed upload that commander would refuse (here 12 m east of home, outside the 10 m geofence) ends
// with the protocol's error code (MAV_MISSION_INVALID_PARAM5_X) after a STATUSTEXT naming the reason and the
// item; nothing reaches commander's topic.
TEST_F(NetGate, UploadOutsideTheGeofence_ErrorCodeNotPublished) {
  auto far = waypoints_of(3);
  far[1].east_m = 12;
  for (int i = 0; i < 2; ++i) {  // the second is a new upload of the same: refused again
    mav::MissionUploader up(far, 0.2);
    ASSERT_EQ(run_upload(up), mav::MissionUploader::Status::Refused);
    EXPECT_EQ(up.result(), mav::MissionResult::InvalidParam5X);
  }
  const auto texts = ground_->all<mav::StatusText>();
  ASSERT_FALSE(texts.empty());
  EXPECT_EQ(mav::text_of(texts.front()), "mission refused: outside the geofence (item 1)");
  step(20);
  EXPECT_EQ(uploads_seen(), 0U);
  // Valid messages: the sender is the ground station, and the verdict the kernel counts is "valid".
  EXPECT_GE(kernel_->net_stats().judged_valid, 8U);
  EXPECT_EQ(kernel_->net_stats().judged_refused, 0U);
}

// MAVLink 2 signing checked by the kernel's gate (launch network.signing_key): only frames signed with the
// key, with a fresh timestamp, reach ext_link; the rest are refused by reason before any service sees them.
constexpr std::string_view kKeyHex = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";

class NetGateSigned : public NetGate {
 protected:
  [[nodiscard]] std::string launch_text() const override {
    return std::string(kNetLaunch) + "network { signing_key: \"" + std::string(kKeyHex) + "\" }\n";
  }
  void SetUp() override {
    NetGate::SetUp();
    if (ground_) ground_->key = *mav::SigningKey::from_hex(kKeyHex);
  }
};

TEST_F(NetGateSigned, SignedUpload_Accepted) {
  EXPECT_TRUE(kernel_->net_stats().signing);
  mav::MissionUploader up(waypoints_of(2), 0.2);
  ASSERT_EQ(run_upload(up), mav::MissionUploader::Status::Accepted);
  EXPECT_EQ(uploads_seen(), 1U);
  EXPECT_EQ(kernel_->net_stats().signing_refused, 0U);
}

TEST_F(NetGateSigned, UnsignedUpload_RefusedByTheGateNeverRelayed) {
  ground_->key.reset();
  mav::MissionUploader up(waypoints_of(2), 0.2);
  EXPECT_EQ(run_upload(up, 300), mav::MissionUploader::Status::InProgress) << "nothing answers an unsigned upload";
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_GE(st.signing_refused, 1U);
  EXPECT_EQ(st.signing_refused, st.signing_refused_by_reason[static_cast<std::size_t>(mav::SigningRefusal::Unsigned)]);
  EXPECT_EQ(st.relayed, 0U);
  EXPECT_EQ(st.judged_valid + st.judged_refused, 0U) << "ext_link saw nothing";
  EXPECT_EQ(uploads_seen(), 0U);
}

TEST_F(NetGateSigned, WronglySignedUpload_Refused) {
  ground_->key = *mav::SigningKey::from_hex(std::string(64, 'f'));
  mav::MissionUploader up(waypoints_of(2), 0.2);
  EXPECT_EQ(run_upload(up, 300), mav::MissionUploader::Status::InProgress);
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_GE(st.signing_refused_by_reason[static_cast<std::size_t>(mav::SigningRefusal::BadSignature)], 1U);
  EXPECT_EQ(st.relayed, 0U);
  EXPECT_EQ(uploads_seen(), 0U);
}

TEST_F(NetGateSigned, ReplayedFrame_Refused) {
  const mav::Frame hb = ground_->frame(ground_heartbeat());
  ground_->send(hb.view());
  ground_->send(hb.view());  // the same bytes again: the same timestamp
  step_until([&] { return kernel_->net_stats().received == 2; });
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_EQ(st.relayed, 1U);
  EXPECT_EQ(st.signing_refused_by_reason[static_cast<std::size_t>(mav::SigningRefusal::Replayed)], 1U);
}

// The replay attack on the signing check. A socket plays back a recording — frames signed with the right key
// but stamped 2015-01-01: a heartbeat and an upload, retransmitted — before the ground station has spoken, when
// the gate has accepted nothing yet; then the ground station speaks; then the socket replays the ground
// station's heartbeat, captured moments ago, byte for byte. The gate compares timestamps with the wall clock
// from its first frame: nothing of the socket's is relayed, each frame is counted by its reason, and the
// vehicle's telemetry goes to the ground station — the replaying socket hears nothing.
TEST_F(NetGateSigned, RecordedAndReplayedFrames_RefusedTelemetryStaysWithTheGround) {
  Ground replayer(*kernel_->network_port());
  replayer.key = ground_->key;
  replayer.recorded_at = mav::SigningClock::from_sys(std::chrono::sys_days{std::chrono::year{2015} / 1 / 1});
  // When the recording is played back (the ground station's stream, signed with the key) ...
  constexpr std::size_t kRecorded = 12;
  mav::MissionUploader up(waypoints_of(2), 0.2);
  replayer.send(ground_heartbeat());
  replayer.send(up.start());
  for (std::size_t i = 2; i < kRecorded; ++i) replayer.send(i % 2 == 0 ? up.last_sent() : ground_heartbeat());
  step_until([&] { return kernel_->net_stats().received == kRecorded; });
  step(50);  // 0.2 s: 10 telemetry periods
  // ... then none of it was relayed: refused as stale, and nobody hears the vehicle yet.
  EXPECT_EQ(kernel_->net_stats().relayed, 0U) << "a recorded frame reached ext_link";
  EXPECT_EQ(kernel_->net_stats().signing_refused_by_reason[static_cast<std::size_t>(mav::SigningRefusal::Stale)], kRecorded);
  EXPECT_EQ(kernel_->net_stats().judged_valid, 0U);
  replayer.collect();
  EXPECT_TRUE(replayer.received.empty() && replayer.raw.empty()) << "telemetry followed the recording";

  // When the ground station speaks, its frame stamped from the wall clock is accepted and telemetry flows ...
  const mav::Frame captured = ground_->frame(ground_heartbeat());
  ground_->send(captured.view());
  step_until([&] {
    ground_->collect();
    return !ground_->all<mav::LocalPositionNed>().empty();
  });
  const kernel::NetStats before = kernel_->net_stats();
  EXPECT_EQ(before.relayed, 1U);
  EXPECT_EQ(before.judged_valid, 1U);
  // ... and when the socket replays that frame, the replays are refused and the telemetry stays.
  constexpr std::size_t kReplays = 3;
  for (std::size_t i = 0; i < kReplays; ++i) replayer.send(captured.view());
  step_until([&] { return kernel_->net_stats().received == before.received + kReplays; });
  ground_->clear();
  step(50);
  const kernel::NetStats st = kernel_->net_stats();
  EXPECT_EQ(st.relayed, before.relayed) << "a replayed frame reached ext_link";
  EXPECT_EQ(st.signing_refused_by_reason[static_cast<std::size_t>(mav::SigningRefusal::Replayed)], kReplays);
  EXPECT_EQ(st.signing_refused, kRecorded + kReplays);
  EXPECT_EQ(st.judged_valid, before.judged_valid);
  EXPECT_EQ(st.judged_refused, 0U);
  EXPECT_EQ(uploads_seen(), 0U);
  replayer.collect();
  ground_->collect();
  EXPECT_TRUE(replayer.received.empty() && replayer.raw.empty()) << "telemetry followed the replayed frames";
  EXPECT_FALSE(ground_->all<mav::LocalPositionNed>().empty()) << "telemetry still goes to the ground station";
}

// network.ground_address (PX4's `-o 14550`): the vehicle's telemetry goes there before any ground station has
// spoken, so a ground station that only listens (QGroundControl on 14550) sees the vehicle.
class NetGateGroundAddress : public NetGate {
 protected:
  NetGateGroundAddress() {
    auto s = sys::UdpSocket::bind(sys::UdpAddress::loopback(0), sys::Blocking::No);
    EXPECT_TRUE(s.has_value());
    if (s) listener_ = std::move(*s);
  }
  [[nodiscard]] std::string launch_text() const override {
    auto bound = listener_.local_address();
    EXPECT_TRUE(bound.has_value());
    return std::string(kNetLaunch) + "network { ground_address: \"127.0.0.1:" + std::to_string(bound ? bound->port : 0) +
           "\" }\n";
  }
  sys::UdpSocket listener_;
};

TEST_F(NetGateGroundAddress, ListeningGroundStation_GetsTelemetryWithoutSending) {
  std::optional<mav::Heartbeat> heartbeat;
  std::array<std::byte, 512> buf{};
  step_until([&] {
    while (auto r = listener_.receive(buf)) {
      auto p = mav::decode(std::span<const std::byte>(buf.data(), r->size));
      if (p && std::holds_alternative<mav::Heartbeat>(p->message)) heartbeat = std::get<mav::Heartbeat>(p->message);
    }
    return heartbeat.has_value();
  });
  ASSERT_TRUE(heartbeat.has_value());
  EXPECT_EQ(heartbeat->type, mav::kMavTypeQuadrotor);
  EXPECT_EQ(kernel_->net_stats().received, 0U) << "nobody sent anything";
  EXPECT_EQ(kernel_->net_stats().unsent_no_ground, 0U);
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
  EXPECT_NE(r.out.find("MAV_MISSION_INVALID_PARAM5_X"), std::string::npos) << r.out;
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
