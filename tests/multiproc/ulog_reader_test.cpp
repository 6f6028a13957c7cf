// `rejuv run --ulog` read back by a reader Rejuv did not write (docs/ulog.md): @foxglove/ulog on Node.js
// (tests/ulog_reader/read_ulog.js, installed into build/<preset>/ulog_reader by ./rejuv's set-up). A short
// flight of the square with SR and the attack; the reader's counts must be what the kernel routed (the run
// summary's `ulog` section, counted where the kernel hands each message over), every topic of the graph
// present, timestamps never decreasing, the launch file's SR parameters and the checkpoints and rollbacks
// of the summary in the log.
#include <gtest/gtest.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cmath>
#include <string>
#include <vector>

#include "rejuv/launch/launch.hpp"
#include "../node_script.hpp"
#include "../rejuv_cli.hpp"
#include "summary.pb.h"
#include "../test_domain.hpp"

namespace rejuv {
namespace {

using google::protobuf::Struct;
using google::protobuf::Value;
using test_support::kRepo;
using test_support::slurp;

const std::filesystem::path kReaderDir = std::filesystem::path(REJUV_BINARY_DIR) / "ulog_reader";

// Runs `node read_ulog.js file` with the reader's modules; its stdout to `out`. The exit code, -1 on a signal.
int run_reader(const std::filesystem::path& file, const std::filesystem::path& out) {
  const pid_t pid = test_support::start_node_script(kRepo / "tests/ulog_reader/read_ulog.js", kReaderDir / "node_modules",
                                                    {file.string()}, out);
  int status = 0;
  if (pid < 0 || ::waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

using test_support::json_at;

class UlogReader : public test_support::ScratchDirTest {
 protected:
  UlogReader() : ScratchDirTest("rejuv_ulog_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }  // the file and both JSONs, to look at
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
};

TEST_F(UlogReader, SquareWithSr_ReadBackByFoxgloveAsRouted) {
  ASSERT_TRUE(std::filesystem::exists(kReaderDir / "node_modules/@foxglove/ulog/package.json"))
      << "the independent ULog reader is not installed: ./rejuv build installs it (npm ci in "
      << kReaderDir.string() << ")";
  const auto graph = kRepo / "launch/quad_square_paper.launch.pbtxt";
  const auto ulg = dir() / "run.ulg";
  const auto summary_json = dir() / "summary.json";
  // Given a short flight with SR and the attack (4 s after the alignment: several SR cycles at T_MC = 0.3 s),
  // every routed message logged (the full profile; the size budget leaves every topic of the square whole)
  const test_support::CliOutcome run = test_support::run_rejuv(
      dir(), {"run", graph.string(), "--duration", "4", "--domain", std::to_string(test_support::kOwnDdsDomain),
              "--net-port", "0", "--ulog", ulg.string(), "--ulog-profile", "full", "--summary-json",
              summary_json.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  proto::RunSummary summary;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(summary_json), &summary).ok());
  ASSERT_TRUE(summary.has_ulog());
  EXPECT_EQ(summary.ulog().bytes(), std::filesystem::file_size(ulg));

  // When @foxglove/ulog reads it
  const auto reader_json = dir() / "reader.json";
  ASSERT_EQ(run_reader(ulg, reader_json), 0) << "read_ulog.js failed on " << ulg;
  Struct r;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(reader_json), &r).ok()) << slurp(reader_json);

  // Then every routed message is there, topic by topic, and every topic of the graph is a subscription
  const Struct& topics = json_at(r, "topics").struct_value();
  ASSERT_FALSE(summary.ulog().routed_by_topic().empty());
  std::uint64_t routed = 0;
  for (const auto& [name, count] : summary.ulog().routed_by_topic()) {
    ASSERT_TRUE(topics.fields().contains(name)) << name;
    EXPECT_EQ(json_at(json_at(topics, name).struct_value(), "count").number_value(), static_cast<double>(count)) << name;
    routed += count;
  }
  EXPECT_EQ(topics.fields_size(), summary.ulog().routed_by_topic_size() + summary.ulog().px4_by_topic_size() + 1)
      << "the topics, PX4's and rejuv_sr_event";
  for (const char* busy : {"sensor_gyro", "vehicle_state", "actuator_outputs", "ground_truth", "sr_mode"}) {
    EXPECT_GT(summary.ulog().routed_by_topic().at(busy), 0u) << busy;
  }
  EXPECT_EQ(json_at(json_at(topics, "rejuv_sr_event").struct_value(), "count").number_value(),
            static_cast<double>(summary.ulog().sr_events()));
  // The kernel publishes an SrMode when the mode changes (and once at the start), not at every step: no more of
  // them than SR events, of which every mode change is one.
  EXPECT_LE(summary.ulog().routed_by_topic().at("sr_mode"), summary.ulog().sr_events());
  // PX4's topics: one message each per estimate (vehicle_state) and per ground-truth sample, as read back
  ASSERT_EQ(summary.ulog().px4_by_topic_size(), 4) << summary.ulog().DebugString();
  std::uint64_t px4 = 0;
  for (const auto& [name, count] : summary.ulog().px4_by_topic()) {
    ASSERT_TRUE(topics.fields().contains(name)) << name;
    EXPECT_EQ(json_at(json_at(topics, name).struct_value(), "count").number_value(), static_cast<double>(count)) << name;
    px4 += count;
  }
  EXPECT_EQ(summary.ulog().px4_by_topic().at("vehicle_local_position"), summary.ulog().routed_by_topic().at("vehicle_state"));
  EXPECT_EQ(summary.ulog().px4_by_topic().at("vehicle_attitude_groundtruth"),
            summary.ulog().routed_by_topic().at("ground_truth"));
  EXPECT_EQ(routed + summary.ulog().sr_events() + px4, summary.ulog().data_messages());
  // … with PX4's field names and units, as a PX4 layout reads them: NED metres (the square flies 3 m up, z ≈ −3),
  // the estimate near the truth, a unit quaternion q[4]
  const auto last = [&](const char* topic) -> const Struct& {
    return json_at(json_at(topics, topic).struct_value(), "last").struct_value();
  };
  const Struct& lp = last("vehicle_local_position");
  const Struct& px4_truth = last("vehicle_local_position_groundtruth");
  for (const char* field : {"x", "y", "z", "vx", "vy", "vz", "heading", "eph", "epv"}) {
    EXPECT_TRUE(lp.fields().contains(field)) << field;
  }
  EXPECT_NEAR(json_at(lp, "z").number_value(), -3.0, 0.5);
  EXPECT_TRUE(json_at(lp, "xy_valid").bool_value() || json_at(lp, "xy_valid").number_value() == 1);
  EXPECT_NEAR(json_at(lp, "x").number_value(), json_at(px4_truth, "x").number_value(), 0.5);
  EXPECT_GT(json_at(lp, "eph").number_value(), 0.0);
  const auto& q = json_at(last("vehicle_attitude"), "q").list_value();
  ASSERT_EQ(q.values_size(), 4);
  double norm = 0;
  for (const auto& c : q.values()) norm += c.number_value() * c.number_value();
  EXPECT_NEAR(norm, 1.0, 1e-3);
  EXPECT_EQ(json_at(r, "data_messages").number_value(), static_cast<double>(summary.ulog().data_messages()));
  EXPECT_EQ(json_at(r, "log_count").number_value(), static_cast<double>(summary.ulog().logged_strings()));

  // … with timestamps that never decrease, ending at the run's end (simulated time)
  EXPECT_TRUE(json_at(r, "ordered").bool_value());
  for (const auto& [name, t] : topics.fields()) {
    EXPECT_TRUE(json_at(t.struct_value(), "nondecreasing").bool_value()) << name;
  }
  const auto& range = json_at(r, "time_range_us").list_value();
  ASSERT_EQ(range.values_size(), 2);
  EXPECT_LE(range.values(0).number_value(), range.values(1).number_value());
  EXPECT_NEAR(range.values(1).number_value() / 1e6, summary.sim_time_s(), 0.01);

  // … the launch file's parameters, the run's information
  auto loaded = launch::load_launch(graph);
  ASSERT_TRUE(loaded);
  const Struct& params = json_at(r, "parameters").struct_value();
  EXPECT_NEAR(json_at(params, "sr.t_mc_s").number_value(), loaded->graph.sr().t_mc_s(), 1e-6);
  EXPECT_NEAR(json_at(params, "sr.t_est_s").number_value(), loaded->graph.sr().t_est_s(), 1e-6);
  // … and the values it flew with, defaults applied: the lockstep charges, the alignment, the wind, the attack
  // plan and the mission's timeout (derived from the path when the file sets none)
  EXPECT_NEAR(json_at(params, "lockstep.checkpoint_charge_ms").number_value(),
              launch::checkpoint_charge(loaded->graph.lockstep()).count() * 1e3, 1e-6);
  EXPECT_NEAR(json_at(params, "lockstep.alignment_s").number_value(), launch::alignment(loaded->graph.lockstep()).count(), 1e-6);
  EXPECT_NEAR(json_at(params, "plant.wind_toward_deg").number_value(), loaded->graph.plant().wind_toward_deg(), 1e-6);
  EXPECT_NEAR(json_at(params, "mission.timeout_s").number_value(), launch::mission_timeout(loaded->graph.mission()).count(), 1e-3);
  ASSERT_GE(loaded->graph.attack().attacks_size(), 1);
  EXPECT_EQ(json_at(params, "attack.0.kind").number_value(), loaded->graph.attack().attacks(0).kind());
  EXPECT_EQ(json_at(params, "ekf2.limits.max_processes").number_value(),
            launch::sandbox_limits(loaded->graph, *launch::find_service(loaded->graph, "ekf2")).max_processes);
  const Struct& info = json_at(r, "info").struct_value();
  EXPECT_EQ(json_at(info, "sys_name").string_value(), "Rejuv");
  EXPECT_EQ(json_at(info, "graph").string_value(), loaded->graph.name());
  EXPECT_EQ(json_at(info, "seed").number_value(), static_cast<double>(loaded->graph.seed()));
  EXPECT_EQ(json_at(info, "attack.0.service").string_value(), loaded->graph.attack().attacks(0).service());

  // … and the checkpoints and rollbacks of the run, as logged strings
  ASSERT_GT(summary.checkpoints(), 0u);
  ASSERT_GT(summary.rollbacks(), 0u);
  const Struct& matching = json_at(r, "logs_matching").struct_value();
  EXPECT_EQ(json_at(matching, "checkpoint").number_value(), static_cast<double>(summary.checkpoints()));
  EXPECT_EQ(json_at(matching, "rollback").number_value(), static_cast<double>(summary.rollbacks()));
  EXPECT_GT(json_at(matching, "mode").number_value(), 0);

  // … and field values decoded through the IDL-derived formats: the vehicle hovers near 3 m (NED z ≈ −3)
  const Struct& truth = json_at(json_at(topics, "ground_truth").struct_value(), "last").struct_value();
  const auto& p = json_at(truth, "p_N_m").list_value();
  ASSERT_EQ(p.values_size(), 3);
  EXPECT_NEAR(p.values(2).number_value(), -3.0, 0.5);
  EXPECT_NEAR(json_at(truth, "timestamp_ns").number_value() / 1e3, json_at(truth, "timestamp").number_value(), 5e3)
      << "the struct's own stamp [ns] and the log's [µs] agree (lockstep: within a step)";
  const double last_mode = json_at(json_at(json_at(topics, "sr_mode").struct_value(), "last").struct_value(), "mode").number_value();
  EXPECT_GE(last_mode, 0);
  EXPECT_LE(last_mode, 4);
}

}  // namespace
}  // namespace rejuv
