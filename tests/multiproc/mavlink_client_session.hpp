// `rejuv run` against a MAVLink 2 ground station Rejuv did not write: node-mavlink (tests/mavlink_client/
// client.js, installed into build/<preset>/mavlink_client by ./rejuv's set-up; docs/mavlink.md). What the
// lockstep tests (mavlink_client_test.cpp) and the real-time one (mavlink_client_realtime_test.cpp) share: the
// signed square started with `rejuv run`, the client started and waited for, and the checks of a QGC-style
// session (client.js --qgc).
#pragma once

#include <gtest/gtest.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "../node_script.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "summary.pb.h"

namespace rejuv::test_support {

inline const std::filesystem::path kClientDir = std::filesystem::path(REJUV_BINARY_DIR) / "mavlink_client";
inline constexpr std::string_view kKey = "6c1a4e2f9b0d7c3e5a8f1b2d4c6e8a0b3d5f7a9c1e2b4d6f8a0c2e4b6d8f0a1c";
inline constexpr std::string_view kWrongKey = "ffeeddccbbaa99887766554433221100ffeeddccbbaa99887766554433221100";

// Starts `node client.js args…` with the client's modules; stdout to `out`. The child's pid, or -1.
inline pid_t start_client(const std::vector<std::string>& client_args, const std::filesystem::path& out) {
  return start_node_script(kRepo / "tests/mavlink_client/client.js", kClientDir / "node_modules", client_args, out);
}

// Waits up to `limit` for the client to exit (it gives up by itself after its --timeout), then ends it with
// SIGTERM: it prints its report and exits 0 only if its session was complete (client.js). Killed if it has not
// exited 10 s later.
inline int wait_client(pid_t pid, std::chrono::seconds limit) {
  int status = 0;
  const auto wait_until = [&](std::chrono::steady_clock::time_point deadline) {
    while (std::chrono::steady_clock::now() < deadline) {
      if (::waitpid(pid, &status, WNOHANG) == pid) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds{50});
    }
    return false;
  };
  if (wait_until(std::chrono::steady_clock::now() + limit)) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  ::kill(pid, SIGTERM);
  if (wait_until(std::chrono::steady_clock::now() + std::chrono::seconds{10})) {
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  ADD_FAILURE() << "the MAVLink client did not exit within " << limit.count() << " s, nor 10 s after SIGTERM";
  return -1;
}

// How `rejuv run` keeps time: lockstep with the plant, or wall-clock time with the real-time plan (--realtime).
enum class RunClock { Lockstep, Realtime };

class MavlinkClientTest : public ScratchDirTest {
 protected:
  MavlinkClientTest() : ScratchDirTest("rejuv_mavlink_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  [[nodiscard]] std::filesystem::path summary_json() const { return dir() / "summary.json"; }

  // `rejuv run` started for `duration` seconds on the square with the key in its network block (the policy
  // path made absolute for the copy, written as `graph_name`; `network_extra`: more fields of that block), its
  // summary in summary_json(); its pid and the port its network gate bound.
  void start_signed_square(const std::string& graph_name, const std::string& duration, RunClock clock,
                           pid_t& rejuv_run, std::uint16_t& port, const std::string& network_extra = "") {
    std::string graph_text = slurp(kRepo / "launch/quad_square_paper.launch.pbtxt");
    const std::string relative = "\"../policies/quad_sr.policy.pbtxt\"";
    const auto policy_at = graph_text.find(relative);
    ASSERT_NE(policy_at, std::string::npos);
    graph_text.replace(policy_at, relative.size(), "\"" + (kRepo / "policies/quad_sr.policy.pbtxt").string() + "\"");
    graph_text += "\nnetwork { signing_key: \"" + std::string(kKey) + "\" " + network_extra + " }\n";
    const auto graph = dir() / graph_name;
    std::ofstream(graph) << graph_text;
    std::vector<std::string> args{"run", graph.string(), "--duration", duration, "--net-port", "0", "--domain",
                                  std::to_string(kOwnDdsDomain), "--summary-json", summary_json().string()};
    if (clock == RunClock::Realtime) args.emplace_back("--realtime");
    rejuv_run = start_program(dir(), kRejuv, args);
    ASSERT_GT(rejuv_run, 0) << "cannot start rejuv run";
    port = bound_gate_port(dir(), rejuv_run, std::chrono::seconds{60});
    if (port == 0) {
      const CliOutcome ended = wait_program(dir(), rejuv_run);
      FAIL() << "rejuv run did not report its network gate's port:\n" << ended.err;
    }
  }

  // What a session of client.js against `rejuv run` left: the client's JSON report and the run's summary.
  struct Session {
    std::string client_text;
    proto::RunSummary summary;
  };
  // A session: the signed square started (start_signed_square), client.js told its port and key, then
  // `client_args`; both waited for (the client up to `client_limit` after the run ended, then ended with SIGTERM:
  // wait_client), each expected to exit 0, and what they left read into `session`. In lockstep the session's
  // limit is the run's duration, in vehicle time: the client's wall-clock --timeout only guards against a lost
  // harness, since the pace of a lockstep run is the machine's (a loaded one flies the same mission in several
  // times the wall time). Use with ASSERT_NO_FATAL_FAILURE.
  void fly_session(const std::string& graph_name, const std::string& duration, RunClock clock,
                   const std::vector<std::string>& client_args, std::chrono::seconds client_limit, Session& session) {
    ASSERT_TRUE(std::filesystem::exists(kClientDir / "node_modules/node-mavlink/package.json"))
        << "the MAVLink client is not installed: ./rejuv build installs it (npm ci in " << kClientDir.string() << ")";
    pid_t rejuv_run = -1;
    std::uint16_t port = 0;
    ASSERT_NO_FATAL_FAILURE(start_signed_square(graph_name, duration, clock, rejuv_run, port));
    std::vector<std::string> args{"--port", std::to_string(port), "--key", std::string(kKey)};
    args.insert(args.end(), client_args.begin(), client_args.end());
    const auto client_out = dir() / "client.json";
    const pid_t client = start_client(args, client_out);
    if (client <= 0) ::kill(rejuv_run, SIGTERM);
    const CliOutcome run = wait_program(dir(), rejuv_run);
    ASSERT_GT(client, 0) << "cannot start node";
    const int client_exit = wait_client(client, client_limit);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    session.client_text = slurp(client_out);
    EXPECT_EQ(client_exit, 0) << session.client_text;
    ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(summary_json()), &session.summary).ok());
  }
};

// The kernel's gate refused the client's unsigned, wrongly signed and recorded (stamped 2015) frames (client.js
// --wrong-key) before ext_link saw them.
inline void expect_forgeries_refused(const proto::RunSummary& summary) {
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
}

// The checks of a QGC-style session (client.js --qgc, its JSON report `client_text`) and of the run's summary:
// the connection (capabilities, home, the whole parameter list, the launch mission downloaded), the flight of
// the mission uploaded in global coordinates (reached as an item and by position, downloaded as uploaded), the
// mission cleared and downloaded again, RTL flown, a rollback reported in STATUSTEXT, every vehicle frame
// verified with the key.
inline void expect_qgc_session(const std::string& client_text, const proto::RunSummary& summary) {
  using google::protobuf::Value;
  google::protobuf::Struct report;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(client_text, &report).ok()) << client_text;
  // The connection: capabilities say MISSION_INT and COMMAND_INT; home is PX4 SITL's; the parameters all came.
  const auto capabilities = static_cast<std::uint64_t>(json_at(report, "autopilot_version_capabilities").number_value());
  EXPECT_NE(capabilities & 4U, 0U) << client_text;
  EXPECT_NE(capabilities & 8U, 0U) << client_text;
  EXPECT_NEAR(json_at(report, "home").struct_value().fields().at("lat").number_value(), 47.397742, 1e-6) << client_text;
  EXPECT_NEAR(json_at(report, "home").struct_value().fields().at("alt_m").number_value(), 488, 1e-3) << client_text;
  EXPECT_GE(json_at(report, "param_count").number_value(), 20) << client_text;
  EXPECT_EQ(json_at(report, "params").struct_value().fields_size(), json_at(report, "param_count").number_value());
  // The SR scheme's launch values (launch/quad_square_paper.launch.pbtxt's sr block), integers as INT32.
  const auto& params = json_at(report, "params").struct_value().fields();
  const auto& types = json_at(report, "param_types").struct_value().fields();
  const auto param = [&](const std::string& name) { return params.contains(name) ? params.at(name).number_value() : -1.0; };
  EXPECT_NEAR(param("RJ_SR_T_MC"), 0.3, 1e-6) << client_text;
  EXPECT_NEAR(param("RJ_SR_RHO_S"), 0.0894, 1e-6) << client_text;
  EXPECT_EQ(param("RJ_SR_KEEP_GEN"), 2) << client_text;
  EXPECT_EQ(param("RJ_SR_ENABLED"), 1) << client_text;
  EXPECT_EQ(types.contains("RJ_SR_KEEP_GEN") ? types.at("RJ_SR_KEEP_GEN").number_value() : -1, 6) << "INT32";
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
  // The mission cleared: acknowledged, and the vehicle holds at its setpoint, at the waypoint it had reached
  // (docs/mavlink.md "Clearing the mission"): a download returns that one item.
  EXPECT_EQ(json_at(report, "clear_ack").number_value(), 0) << "MAV_MISSION_ACCEPTED";
  const auto& cleared = json_at(report, "download_after_clear").list_value();
  ASSERT_EQ(cleared.values_size(), 1) << client_text;
  EXPECT_EQ(cleared.values(0).struct_value().fields().at("frame").number_value(), 6) << "GLOBAL_RELATIVE_ALT_INT";
  EXPECT_LT(json_at(report, "hold_offset_m").number_value(), 0.5) << client_text;
  EXPECT_EQ(json_at(report, "rtl_ack").number_value(), 0) << "MAV_RESULT_ACCEPTED";
  EXPECT_TRUE(json_at(report, "returned_home").bool_value()) << client_text;
  EXPECT_TRUE(json_at(report, "rollback_statustext").has_string_value()) << client_text;
  // Signing both ways: every vehicle frame verified with the key.
  EXPECT_GT(json_at(report, "vehicle_frames").number_value(), 100) << client_text;
  EXPECT_EQ(json_at(report, "vehicle_frames_verified").number_value(), json_at(report, "vehicle_frames").number_value())
      << client_text;
  EXPECT_TRUE(summary.network().signing());
  EXPECT_TRUE(summary.attack());
  EXPECT_GT(summary.attacks(), 0U);
  EXPECT_GT(summary.rollbacks(), 0U);
}

}  // namespace rejuv::test_support
