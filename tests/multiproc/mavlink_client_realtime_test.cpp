// The QGC-style session of mavlink_client_test.cpp (client.js --qgc) against `rejuv run --realtime`: the square
// in wall-clock time with the real-time plan (docs/realtime.md), SR and the graph's attacks on, signing on. The
// ground station and the vehicle share one clock here, as they do in the field: the client's retransmissions
// (every 20 ms) carry each request through the secure execution intervals, which last as long as on the vehicle.
// The client gets generous limits (the machine is shared); nothing here asserts a timing.
#include "mavlink_client_session.hpp"

namespace rejuv {
namespace {

using test_support::RunClock;

using MavlinkClientRealtime = test_support::MavlinkClientTest;

// As QGroundControl connects and plans (client.js --qgc) while the vehicle flies in real time: the connection,
// a mission in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT flown and downloaded again, the mission cleared, RTL flown,
// rollbacks reported as STATUSTEXT, every vehicle frame verified with the key; the client's unsigned, wrongly
// signed and recorded frames (--wrong-key, all along) refused by the kernel's gate.
TEST_F(MavlinkClientRealtime, QgcStyleSessionInRealTimeWithSignedVehicleFrames) {
  // 420 s of flight, for a client that gives up after 400 s.
  Session session;
  ASSERT_NO_FATAL_FAILURE(fly_session("qgc_realtime.launch.pbtxt", "420", RunClock::Realtime,
                                      {"--qgc", "--wrong-key", std::string(test_support::kWrongKey), "--timeout",
                                       "400", "--target", "1.5,-1,-3.5"},
                                      std::chrono::seconds{120}, session));
  EXPECT_EQ(session.summary.charging().charge(), "none") << "a real-time run";
  test_support::expect_qgc_session(session.client_text, session.summary);
  test_support::expect_forgeries_refused(session.summary);
}

}  // namespace
}  // namespace rejuv
