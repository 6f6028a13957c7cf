// `rejuv run` against a MAVLink 2 ground station Rejuv did not write: node-mavlink (tests/mavlink_client/
// client.js, installed into build/<preset>/mavlink_client by ./rejuv's set-up; docs/mavlink.md). The square,
// in lockstep, with SR, and MAVLink signing on (a key in the launch file's network block): the client
// exchanges heartbeats, uploads a mission through the secure execution interval (acknowledged
// MAV_MISSION_ACCEPTED), sees the vehicle reach the uploaded waypoint in LOCAL_POSITION_NED and a rollback in
// STATUSTEXT; its unsigned, wrongly signed and recorded (stamped 2015) uploads are refused by the kernel's gate
// (the run summary). The QGC-style session in real time: mavlink_client_realtime_test.cpp.
#include "mavlink_client_session.hpp"
#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/sys/udp.hpp"

namespace rejuv {
namespace {

using google::protobuf::Struct;
using test_support::json_at;
using test_support::kKey;
using test_support::kWrongKey;
using test_support::RunClock;
using test_support::slurp;

using MavlinkClient = test_support::MavlinkClientTest;

TEST_F(MavlinkClient, NodeMavlinkUploadsSignedThroughTheSeiAndSeesTheFlight) {
  // Given the square with the key in its network block, when node-mavlink talks to it while it flies
  // (lockstep; the client told the port the kernel bound, its session limited by the run's 240 s of flight) …
  Session session;
  ASSERT_NO_FATAL_FAILURE(fly_session("signed.launch.pbtxt", "240", RunClock::Lockstep,
                                      {"--wrong-key", std::string(kWrongKey), "--timeout", "900", "--target",
                                       "-0.6,-0.4,-3.3"},
                                      std::chrono::seconds{10}, session));
  const std::string& client_text = session.client_text;
  // … then the client saw the vehicle, its upload accepted and flown, and a rollback reported.
  Struct report;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(client_text, &report).ok()) << client_text;
  EXPECT_TRUE(json_at(report, "heartbeat").bool_value());
  EXPECT_EQ(json_at(report, "vehicle_type").number_value(), 2) << "MAV_TYPE_QUADROTOR";
  EXPECT_EQ(json_at(report, "upload_ack").number_value(), 0) << "MAV_MISSION_ACCEPTED";
  // The upload began in the pre-flight alignment (the SEI): its first transmissions were dropped by the gate.
  EXPECT_GE(json_at(report, "upload_unanswered").number_value(), 1) << client_text;
  EXPECT_TRUE(json_at(report, "reached_target").bool_value()) << client_text;
  EXPECT_GT(json_at(report, "distance_at_ack_m").number_value(), json_at(report, "min_distance_after_ack_m").number_value() + 0.3);
  EXPECT_TRUE(json_at(report, "rollback_statustext").has_string_value()) << client_text;
  // The kernel's gate refused the unsigned, the wrongly signed and the recorded (stamped 2015) frames before
  // ext_link saw them (the client's own stream, stamped from its wall clock, got its upload through: above).
  test_support::expect_forgeries_refused(session.summary);
  EXPECT_GT(session.summary.rollbacks(), 0U);
  EXPECT_GT(session.summary.network().dropped_secure_interval(), 0U);
}

// As QGroundControl connects and plans (client.js --qgc), with signing on: AUTOPILOT_VERSION and HOME_POSITION
// asked for with MAV_CMD_REQUEST_MESSAGE, the whole parameter list, a mission download; then a mission in
// MAV_FRAME_GLOBAL_RELATIVE_ALT_INT against the home learnt, flown (MISSION_ITEM_REACHED, and GLOBAL_POSITION_INT
// within the acceptance radius), downloaded again, cleared (the vehicle holds at its setpoint: a download returns
// that one item), and a return to launch flown — through the SEI, with
// rollbacks. Every frame the vehicle sent verified with the key in node-mavlink (the gate signs them).
TEST_F(MavlinkClient, QgcStyleSessionInGlobalCoordinatesWithSignedVehicleFrames) {
  Session session;
  ASSERT_NO_FATAL_FAILURE(fly_session("qgc.launch.pbtxt", "400", RunClock::Lockstep,
                                      {"--qgc", "--timeout", "900", "--target", "1.5,-1,-3.5"}, std::chrono::seconds{10},
                                      session));
  test_support::expect_qgc_session(session.client_text, session.summary);
}

// A ground station that only listens (QGroundControl on 14550; PX4's `mavlink start -o 14550`): with the
// graph's `network.ground_address` naming its port, `rejuv run` sends it the vehicle's frames from the first MC
// window on, before anything has come in — HEARTBEATs, signed by the gate with the graph's key.
TEST_F(MavlinkClient, ListeningGroundStationAtGroundAddress_GetsSignedHeartbeatsWithoutSending) {
  auto listening = sys::UdpSocket::bind(sys::UdpAddress::loopback(0), sys::Blocking::No);
  ASSERT_TRUE(listening.has_value());
  auto bound = listening->local_address();
  ASSERT_TRUE(bound.has_value());
  pid_t rejuv_run = -1;
  std::uint16_t port = 0;
  ASSERT_NO_FATAL_FAILURE(start_signed_square("listening.launch.pbtxt", "30", RunClock::Lockstep, rejuv_run, port,
                                              "ground_address: \"127.0.0.1:" + std::to_string(bound->port) + "\""));
  const auto key = mavlink::SigningKey::from_hex(kKey);
  ASSERT_TRUE(key.has_value());
  std::size_t heartbeats = 0, signed_heartbeats = 0;
  std::array<std::byte, 512> buf{};
  // Until the run has ended (30 s of flight, lockstep): everything that arrived is read.
  bool ended = false;
  while (!ended) {
    siginfo_t info{};
    ended = ::waitid(P_PID, static_cast<id_t>(rejuv_run), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == rejuv_run;
    while (auto got = listening->receive(buf)) {
      const std::span<const std::byte> datagram(buf.data(), got->size);
      auto packet = mavlink::decode(datagram);
      if (!packet || !std::holds_alternative<mavlink::Heartbeat>(packet->message)) continue;
      ++heartbeats;
      EXPECT_EQ(std::get<mavlink::Heartbeat>(packet->message).type, mavlink::kMavTypeQuadrotor);
      auto frame = mavlink::split_frame(datagram);
      if (frame && frame->signature && mavlink::signature_matches(*key, *frame)) ++signed_heartbeats;
    }
    if (!ended) std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }
  const test_support::CliOutcome run = test_support::wait_program(dir(), rejuv_run);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_GE(heartbeats, 5U) << "HEARTBEAT at 1 Hz over 30 s of flight, in the MC windows";
  EXPECT_EQ(signed_heartbeats, heartbeats) << "every one signed with the graph's key";
  proto::RunSummary summary;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(summary_json()), &summary).ok());
  EXPECT_EQ(summary.network().received(), 0U) << "nobody sent anything";
  EXPECT_EQ(summary.network().unsent_no_ground(), 0U) << "a ground station was known from the start";
  EXPECT_GT(summary.network().sent(), 0U);
}

}  // namespace
}  // namespace rejuv
