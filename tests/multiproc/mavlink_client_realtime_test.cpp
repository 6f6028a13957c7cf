// The QGC-style session of mavlink_client_test.cpp (client.js --qgc) against `rejuv run --realtime`: the square
// in wall-clock time with the real-time plan (docs/realtime.md), SR and the graph's attacks on, signing on. The
// ground station and the vehicle now share one clock, as they do in the field: the client's retransmissions
// (every 20 ms) carry each request through the secure execution intervals, which last as long as on the vehicle.
// The client gets generous limits (the machine is shared); nothing here asserts a timing.
#include "mavlink_client_session.hpp"

namespace rejuv {
namespace {

using test_support::kClientDir;
using test_support::kKey;
using test_support::RunClock;
using test_support::slurp;

using MavlinkClientRealtime = test_support::MavlinkClientTest;

// As QGroundControl connects and plans (client.js --qgc) while the vehicle flies in real time: the connection,
// a mission in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT flown and downloaded again, the mission cleared, RTL flown,
// rollbacks reported as STATUSTEXT, every vehicle frame verified with the key; the client's unsigned, wrongly
// signed and recorded frames (--wrong-key, all along) refused by the kernel's gate.
TEST_F(MavlinkClientRealtime, QgcStyleSessionInRealTimeWithSignedVehicleFrames) {
  ASSERT_TRUE(std::filesystem::exists(kClientDir / "node_modules/node-mavlink/package.json"))
      << "the MAVLink client is not installed: ./rejuv build installs it (npm ci in " << kClientDir.string() << ")";
  pid_t rejuv_run = -1;
  std::uint16_t port = 0;
  // 420 s of flight; the session took about 240 s of it on an idle machine.
  ASSERT_NO_FATAL_FAILURE(start_signed_square("qgc_realtime.launch.pbtxt", "420", RunClock::Realtime, rejuv_run, port));
  const auto client_out = dir() / "client.json";
  const pid_t client = test_support::start_client(
      {"--port", std::to_string(port), "--key", std::string(kKey), "--qgc", "--wrong-key",
       std::string(test_support::kWrongKey), "--timeout", "400", "--target", "1.5,-1,-3.5"},
      client_out);
  if (client <= 0) ::kill(rejuv_run, SIGTERM);
  const test_support::CliOutcome run = test_support::wait_program(dir(), rejuv_run);
  ASSERT_GT(client, 0) << "cannot start node";
  const int client_exit = test_support::wait_client(client, std::chrono::seconds{120});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const std::string client_text = slurp(client_out);
  EXPECT_EQ(client_exit, 0) << client_text;
  proto::RunSummary summary;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(summary_json()), &summary).ok());
  EXPECT_EQ(summary.charging().charge(), "none") << "a real-time run";
  test_support::expect_qgc_session(client_text, summary);
  test_support::expect_forgeries_refused(summary);
}

}  // namespace
}  // namespace rejuv
