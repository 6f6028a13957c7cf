// `rejuv run` against a MAVLink 2 ground station Rejuv did not write: node-mavlink (tests/mavlink_client/
// client.js, installed into build/<preset>/mavlink_client by ./rejuv's set-up; docs/mavlink.md). The square,
// in lockstep, with SR, and MAVLink signing on (a key in the launch file's network block): the client
// exchanges heartbeats, uploads a mission through the secure execution interval (acknowledged
// MAV_MISSION_ACCEPTED), sees the vehicle reach the uploaded waypoint in LOCAL_POSITION_NED and a rollback in
// STATUSTEXT; its unsigned, wrongly signed and recorded (stamped 2015) uploads are refused by the kernel's gate
// (the run summary).
#include <gtest/gtest.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "../node_script.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "rejuv/sys/udp.hpp"
#include "summary.pb.h"

namespace rejuv {
namespace {

using google::protobuf::Struct;
using google::protobuf::Value;
using test_support::kRepo;
using test_support::slurp;

const std::filesystem::path kClientDir = std::filesystem::path(REJUV_BINARY_DIR) / "mavlink_client";
constexpr std::string_view kKey = "6c1a4e2f9b0d7c3e5a8f1b2d4c6e8a0b3d5f7a9c1e2b4d6f8a0c2e4b6d8f0a1c";
constexpr std::string_view kWrongKey = "ffeeddccbbaa99887766554433221100ffeeddccbbaa99887766554433221100";

// Starts `node client.js args…` with the client's modules; stdout to `out`. The child's pid, or -1.
pid_t start_client(const std::vector<std::string>& client_args, const std::filesystem::path& out) {
  return test_support::start_node_script(kRepo / "tests/mavlink_client/client.js", kClientDir / "node_modules",
                                         client_args, out);
}

// Waits for the client to exit (it gives up by itself after its --timeout); kills it past `limit`.
int wait_client(pid_t pid, std::chrono::seconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::this_thread::sleep_for(std::chrono::milliseconds{50});
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  ADD_FAILURE() << "the MAVLink client did not exit within " << limit.count() << " s";
  return -1;
}

using test_support::json_at;

class MavlinkClient : public test_support::ScratchDirTest {
 protected:
  MavlinkClient() : ScratchDirTest("rejuv_mavlink_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  [[nodiscard]] std::filesystem::path summary_json() const { return dir() / "summary.json"; }

  // `rejuv run` started for `duration` seconds on the square with the key in its network block (the policy
  // path made absolute for the copy, written as `graph_name`), its summary in summary_json(); its pid and the
  // port its network gate bound.
  void start_signed_square(const std::string& graph_name, const std::string& duration, pid_t& rejuv_run,
                           std::uint16_t& port) {
    std::string graph_text = slurp(kRepo / "launch/quad_square_paper.launch.pbtxt");
    const std::string relative = "\"../policies/quad_sr.policy.pbtxt\"";
    const auto policy_at = graph_text.find(relative);
    ASSERT_NE(policy_at, std::string::npos);
    graph_text.replace(policy_at, relative.size(), "\"" + (kRepo / "policies/quad_sr.policy.pbtxt").string() + "\"");
    graph_text += "\nnetwork { signing_key: \"" + std::string(kKey) + "\" }\n";
    const auto graph = dir() / graph_name;
    std::ofstream(graph) << graph_text;
    rejuv_run = test_support::start_program(
        dir(), test_support::kRejuv,
        {"run", graph.string(), "--duration", duration, "--net-port", "0", "--domain",
         std::to_string(test_support::kOwnDdsDomain), "--summary-json", summary_json().string()});
    ASSERT_GT(rejuv_run, 0) << "cannot start rejuv run";
    port = test_support::bound_gate_port(dir(), rejuv_run, std::chrono::seconds{60});
    if (port == 0) {
      const test_support::CliOutcome ended = test_support::wait_program(dir(), rejuv_run);
      FAIL() << "rejuv run did not report its network gate's port:\n" << ended.err;
    }
  }
};

TEST_F(MavlinkClient, NodeMavlinkUploadsSignedThroughTheSeiAndSeesTheFlight) {
  ASSERT_TRUE(std::filesystem::exists(kClientDir / "node_modules/node-mavlink/package.json"))
      << "the MAVLink client is not installed: ./rejuv build installs it (npm ci in " << kClientDir.string() << ")";
  // Given the square with the key in its network block, when node-mavlink talks to it while it flies
  // (lockstep; the client in wall-clock time, told the port the kernel bound) …
  pid_t rejuv_run = -1;
  std::uint16_t port = 0;
  ASSERT_NO_FATAL_FAILURE(start_signed_square("signed.launch.pbtxt", "240", rejuv_run, port));
  const auto client_out = dir() / "client.json";
  const pid_t client = start_client({"--port", std::to_string(port), "--key", std::string(kKey), "--wrong-key",
                                     std::string(kWrongKey), "--timeout", "60", "--target", "-0.6,-0.4,-3.3"},
                                    client_out);
  if (client <= 0) ::kill(rejuv_run, SIGTERM);
  const test_support::CliOutcome run = test_support::wait_program(dir(), rejuv_run);
  ASSERT_GT(client, 0) << "cannot start node";
  const int client_exit = wait_client(client, std::chrono::seconds{90});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const std::string client_text = slurp(client_out);
  EXPECT_EQ(client_exit, 0) << client_text;
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
  proto::RunSummary summary;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(summary_json()), &summary).ok());
  EXPECT_TRUE(summary.network().signing());
  std::uint64_t unsigned_refused = 0, bad_signature = 0, stale = 0;
  for (const proto::LinkRefusals& r : summary.network().signing_refused_by_reason()) {
    if (r.reason() == "unsigned") unsigned_refused = r.count();
    if (r.reason() == "bad_signature") bad_signature = r.count();
    if (r.reason() == "stale") stale = r.count();
  }
  EXPECT_GE(unsigned_refused, 1U) << summary.network().DebugString();
  EXPECT_GE(bad_signature, 1U) << summary.network().DebugString();
  EXPECT_GE(stale, 1U) << summary.network().DebugString();
  EXPECT_GT(summary.rollbacks(), 0U);
  EXPECT_GT(summary.network().dropped_secure_interval(), 0U);
}

// As QGroundControl connects and plans (client.js --qgc), with signing on: AUTOPILOT_VERSION and HOME_POSITION
// asked for with MAV_CMD_REQUEST_MESSAGE, the whole parameter list, a mission download; then a mission in
// MAV_FRAME_GLOBAL_RELATIVE_ALT_INT against the home learnt, flown (MISSION_ITEM_REACHED, and GLOBAL_POSITION_INT
// within the acceptance radius), downloaded again, and a return to launch flown — through the SEI, with
// rollbacks. Every frame the vehicle sent verified with the key in node-mavlink (the gate signs them).
TEST_F(MavlinkClient, QgcStyleSessionInGlobalCoordinatesWithSignedVehicleFrames) {
  ASSERT_TRUE(std::filesystem::exists(kClientDir / "node_modules/node-mavlink/package.json"))
      << "the MAVLink client is not installed: ./rejuv build installs it (npm ci in " << kClientDir.string() << ")";
  pid_t rejuv_run = -1;
  std::uint16_t port = 0;
  ASSERT_NO_FATAL_FAILURE(start_signed_square("qgc.launch.pbtxt", "400", rejuv_run, port));
  const auto client_out = dir() / "client.json";
  const pid_t client = start_client({"--port", std::to_string(port), "--key", std::string(kKey), "--qgc", "--timeout",
                                     "90", "--target", "1.5,-1,-3.5"},
                                    client_out);
  if (client <= 0) ::kill(rejuv_run, SIGTERM);
  const test_support::CliOutcome run = test_support::wait_program(dir(), rejuv_run);
  ASSERT_GT(client, 0) << "cannot start node";
  const int client_exit = wait_client(client, std::chrono::seconds{120});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const std::string client_text = slurp(client_out);
  EXPECT_EQ(client_exit, 0) << client_text;
  Struct report;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(client_text, &report).ok()) << client_text;
  // The connection: capabilities say MISSION_INT and COMMAND_INT; home is PX4 SITL's; the parameters all came.
  const auto capabilities = static_cast<std::uint64_t>(json_at(report, "autopilot_version_capabilities").number_value());
  EXPECT_NE(capabilities & 4U, 0U) << client_text;
  EXPECT_NE(capabilities & 8U, 0U) << client_text;
  EXPECT_NEAR(json_at(report, "home").struct_value().fields().at("lat").number_value(), 47.397742, 1e-6) << client_text;
  EXPECT_NEAR(json_at(report, "home").struct_value().fields().at("alt_m").number_value(), 488, 1e-3) << client_text;
  EXPECT_GE(json_at(report, "param_count").number_value(), 7) << client_text;
  EXPECT_EQ(json_at(report, "params").struct_value().fields_size(), json_at(report, "param_count").number_value());
  EXPECT_GE(json_at(report, "download_before").number_value(), 1) << "the launch mission";
  // The flight: accepted, reached as an item and by position, downloaded as uploaded, RTL flown.
  EXPECT_EQ(json_at(report, "upload_ack").number_value(), 0) << "MAV_MISSION_ACCEPTED";
  bool reached_item_0 = false;
  for (const Value& v : json_at(report, "item_reached").list_value().values()) reached_item_0 |= v.number_value() == 0;
  EXPECT_TRUE(reached_item_0) << client_text;
  EXPECT_LT(json_at(report, "min_global_distance_m").number_value(), 0.3) << client_text;
  const auto& after = json_at(report, "download_after").list_value();
  ASSERT_EQ(after.values_size(), 1) << client_text;
  EXPECT_EQ(after.values(0).struct_value().fields().at("frame").number_value(), 6) << "GLOBAL_RELATIVE_ALT_INT";
  EXPECT_NEAR(after.values(0).struct_value().fields().at("z").number_value(), 3.5, 1e-3) << client_text;
  EXPECT_EQ(json_at(report, "rtl_ack").number_value(), 0) << "MAV_RESULT_ACCEPTED";
  EXPECT_TRUE(json_at(report, "returned_home").bool_value()) << client_text;
  EXPECT_TRUE(json_at(report, "rollback_statustext").has_string_value()) << client_text;
  // Signing both ways: every vehicle frame verified with the key.
  EXPECT_GT(json_at(report, "vehicle_frames").number_value(), 100) << client_text;
  EXPECT_EQ(json_at(report, "vehicle_frames_verified").number_value(), json_at(report, "vehicle_frames").number_value())
      << client_text;
  proto::RunSummary summary;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(summary_json()), &summary).ok());
  EXPECT_GT(summary.rollbacks(), 0U);
}

}  // namespace
}  // namespace rejuv
