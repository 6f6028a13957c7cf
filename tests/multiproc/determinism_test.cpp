// Experiments a researcher can trust: `rejuv run` in lockstep is deterministic for a seed, and SR
// starts with the flight (docs/design.md §6). The real binary on the real flight graph (launch/quad_square_paper) with a
// short alignment and a short T_est, so that a few seconds of flight hold several SR cycles: flown twice with
// one seed, the traces (--csv) are byte-identical and the summaries equal but for their wall-clock fields; a
// flight shorter than T_est has no checkpoint, rollback or rejuvenation timer at all, and its setpoint has not
// moved. No timing is asserted: the charged time is the launch file's model, not a measurement.
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "rejuv/sys/sanitizer.hpp"
#include "summary.pb.h"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
using Outcome = rejuv::test_support::CliOutcome;

// The eight rejuvenated services of the square (all but output_driver, which is driver level).
constexpr std::uint64_t kRejuvenated = 8;

class Determinism : public rejuv::test_support::ScratchDirTest {
 protected:
  Determinism() : ScratchDirTest("rejuv_determinism_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }  // the traces to diff

  // A shipped square (the paper's unless named) with its policy path made absolute, a 2 s alignment and, for the
  // paper's, T_est = 0.5 s; a square that extends the paper's (launch/quad_square) extends that copy.
  std::filesystem::path graph() const {
    // Written once per square: runs started at once read it while the next one starts.
    if (graph_of_ && graph_of_->first == square_) return graph_of_->second;
    graph_of_.emplace(square_, write_graph());
    return graph_of_->second;
  }
  std::filesystem::path write_graph() const {
    std::string text = slurp(kRepo / "launch" / "quad_square_paper.launch.pbtxt");
    const std::string rel = "policy: \"../policies/quad_sr.policy.pbtxt\"";
    text.replace(text.find(rel), rel.size(), "policy: \"" + (kRepo / "policies" / "quad_sr.policy.pbtxt").string() + "\"");
    const std::string t_est = "t_est_s: 3.0";
    text.replace(text.find(t_est), t_est.size(), "t_est_s: 0.5");
    const std::string align = "alignment_s: 20";
    text.replace(text.find(align), align.size(), "alignment_s: 2");
    const auto base = dir_ / "g.launch.pbtxt";
    std::ofstream(base) << text;
    if (square_ == "quad_square_paper.launch.pbtxt") return base;
    const auto extended = dir_ / "extended.launch.pbtxt";
    rejuv::test_support::write_extending(square_, base, extended);
    return extended;
  }
  std::string square_ = "quad_square_paper.launch.pbtxt";
  mutable std::optional<std::pair<std::string, std::filesystem::path>> graph_of_;  // graph()'s file, by square_

  struct Flight {
    Outcome outcome;
    std::string csv;
    rejuv::proto::RunSummary summary;
  };
  void expect_same_flight(const Flight& a, const Flight& b) const;

  // A flight started, not yet waited for (start, then finish: several at once).
  struct Started {
    std::string name;
    pid_t pid = -1;
  };
  // `rejuv run` of graph() with seed 7 on the test's own domain; duration_s empty: to the mission's end.
  Started start(const std::string& name, const std::string& duration_s, std::vector<std::string> extra = {}) const {
    const auto logs = dir_ / name;  // its stdout and stderr (the kernel's log), kept beside the trace
    std::filesystem::create_directories(logs);
    std::vector<std::string> args{"run", graph().string(), "--domain", std::to_string(rejuv::test_support::kOwnDdsDomain),
                                  "--net-port", "0", "--seed", "7", "--csv", (dir_ / (name + ".csv")).string(),
                                  "--summary-json", (dir_ / (name + ".json")).string()};
    if (!duration_s.empty()) args.insert(args.end(), {"--duration", duration_s});
    args.insert(args.end(), extra.begin(), extra.end());
    return Started{.name = name, .pid = rejuv::test_support::start_program(logs, rejuv::test_support::kRejuv, std::move(args))};
  }
  Flight finish(const Started& started) const {
    Flight f;
    f.outcome = rejuv::test_support::wait_program(dir_ / started.name, started.pid);
    f.csv = slurp(dir_ / (started.name + ".csv"));
    const auto parsed = google::protobuf::util::JsonStringToMessage(slurp(dir_ / (started.name + ".json")), &f.summary);
    EXPECT_TRUE(parsed.ok()) << started.name << ": " << parsed.ToString() << "\n" << f.outcome.err;
    return f;
  }
  Flight fly(const std::string& name, const std::string& duration_s, std::vector<std::string> extra = {}) const {
    return finish(start(name, duration_s, std::move(extra)));
  }
};

// Every field measured on the wall clock (or chosen by the OS, the gate's ephemeral port) cleared.
rejuv::proto::RunSummary without_wall_clock(rejuv::proto::RunSummary s) {
  s.clear_checkpoint_ms();
  s.clear_rollback_ms();
  s.clear_image_phases();
  s.clear_realtime_factor();
  s.clear_wall_time_s();
  s.mutable_network()->clear_port();
  // What the machine granted, not what the seed decides: the real-time plan's SCHED_FIFO budget is shared with
  // any other kernel running at the time (ctest -j2), so one flight may say "SCHED_FIFO 100 ms/s" and the other not.
  s.mutable_sandbox_violations()->clear_cgroup();
  rejuv::proto::Charging& c = *s.mutable_charging();
  c.clear_measured_s();
  c.clear_first_checkpoint_ms();
  c.clear_checkpoint_p99_ms();
  c.clear_rollback_p99_ms();
  if (s.has_catch_up()) s.mutable_catch_up()->clear_replay_ms();
  // The ULog holds the kernel's log lines, and some of them say how long the machine took ("the alignment's
  // checkpoint: 8 images by fork in 9.642 ms"): its size follows the wall clock's digits. What it records of the
  // flight is the trace compared above.
  if (s.has_ulog()) s.mutable_ulog()->clear_bytes();
  return s;
}

// Flights "a" and "b": byte-identical traces (the first differing row is in the kept scratch folder when this
// fails) and summaries equal but for the wall clock, field by field so that a failure names the field.
void Determinism::expect_same_flight(const Flight& a, const Flight& b) const {
  EXPECT_TRUE(a.csv == b.csv) << "traces differ: diff " << (dir_ / "a.csv") << " " << (dir_ / "b.csv");
  std::string differences;
  google::protobuf::util::MessageDifferencer diff;
  diff.ReportDifferencesToString(&differences);
  EXPECT_TRUE(diff.Compare(without_wall_clock(a.summary), without_wall_clock(b.summary))) << differences;
}

TEST_F(Determinism, TwoFlightsWithOneSeed_IdenticalTracesAndSummaries) {
  const Flight a = fly("a", "8");
  const Flight b = fly("b", "8");
  ASSERT_EQ(a.outcome.exit_code, 0) << a.outcome.err;
  ASSERT_EQ(b.outcome.exit_code, 0) << b.outcome.err;
  // The flight did what is compared: SR cycles with checkpoints and rollbacks, charged by the model.
  EXPECT_GT(a.summary.checkpoints(), 1U) << a.outcome.out;
  EXPECT_GT(a.summary.rollbacks(), 1U) << a.outcome.out;
  EXPECT_EQ(a.summary.charging().charge(), "model");
  EXPECT_GT(a.summary.charging().charged_s(), 0.0);
  EXPECT_GT(a.csv.size(), 1000U);
  // The flight's first checkpoint takes its images by written pages like every other (the forks were made in
  // the alignment): none of the flight's images is by fork.
  if (!rejuv::sys::kSanitizerBuild) {  // a sanitizer build takes every image by fork (memory_image::prepare_self)
    EXPECT_EQ(a.summary.image_phases().images_by_fork(), 0U) << a.outcome.out;
  }
  EXPECT_EQ(a.summary.charging().priming_images(), kRejuvenated);
  // Per service (ServiceSummary): each rejuvenated one was in every checkpoint (and the alignment's) and
  // restored at every rollback; the driver-level output_driver never; each publishes on its own topics only.
  ASSERT_EQ(a.summary.services_size(), static_cast<int>(kRejuvenated) + 1) << a.outcome.out;
  for (const rejuv::proto::ServiceSummary& s : a.summary.services()) {
    EXPECT_EQ(s.spawns(), 1U) << s.name();
    EXPECT_EQ(s.rejuvenated(), s.name() != "output_driver") << s.name();
    EXPECT_EQ(s.images(), s.rejuvenated() ? a.summary.checkpoints() + 1 : 0U) << s.name();
    EXPECT_EQ(s.restores(), s.rejuvenated() ? a.summary.rollbacks() : 0U) << s.name();
    std::uint64_t by_topic = 0;
    for (const auto& [topic, n] : s.publishes_by_topic()) by_topic += n;
    EXPECT_EQ(by_topic, s.publishes()) << s.name();
    if (s.name() == "ekf2") {
      EXPECT_GT(s.publishes_by_topic().at("vehicle_state"), 1000U);
      EXPECT_EQ(s.publishes_by_topic().size(), 1U);
    }
  }
  expect_same_flight(a, b);
}

// The messages of a ULog file (docs/ulog.md: a 16-byte header, then each message as its size (uint16), its type
// (one byte) and its payload), or an empty list when the file is not a ULog.
struct UlogMessage {
  char type = 0;
  std::string payload;
};
std::vector<UlogMessage> ulog_messages(const std::string& bytes) {
  std::vector<UlogMessage> out;
  if (bytes.size() < 16 || bytes.compare(0, 4, "ULog") != 0) return out;
  for (std::size_t at = 16; at + 3 <= bytes.size();) {
    const std::size_t size = static_cast<unsigned char>(bytes[at]) | (static_cast<unsigned char>(bytes[at + 1]) << 8U);
    if (at + 3 + size > bytes.size()) break;
    out.push_back(UlogMessage{.type = bytes[at + 2], .payload = bytes.substr(at + 3, size)});
    at += 3 + size;
  }
  return out;
}

// A logged string ('L': level, timestamp, text) whose figures the machine decides, not the seed: a duration the
// kernel measured on the wall clock, or the CPU the kernel was pinned to (the one it ran on at boot). What
// else differs between two runs with one seed is a finding.
bool machine_log_line(const UlogMessage& m) {
  if (m.type != 'L' || m.payload.size() < 9) return false;
  const std::string text = m.payload.substr(9);
  for (const char* measured : {" ms", "wall", "on CPU "}) {
    if (text.find(measured) != std::string::npos) return true;
  }
  return false;
}

// Two ULogs of one seed: every message byte-identical, padding included (the plant builds its messages over zeroed
// bytes and the DDS readers take them into zeroed buffers: no padding carries a process's heap or stack into the
// log), but logged strings of the machine (above), which must still be the same lines in the same order.
void expect_same_ulog(const std::filesystem::path& a, const std::filesystem::path& b) {
  const std::vector<UlogMessage> ma = ulog_messages(slurp(a));
  const std::vector<UlogMessage> mb = ulog_messages(slurp(b));
  EXPECT_GT(ma.size(), 1000U) << a;
  EXPECT_EQ(ma.size(), mb.size()) << a << " " << b;
  if (ma.size() != mb.size()) return;
  std::size_t data = 0, machine = 0;
  for (std::size_t i = 0; i < ma.size(); ++i) {
    EXPECT_EQ(ma[i].type, mb[i].type) << "message " << i;
    if (ma[i].type != mb[i].type) return;
    data += ma[i].type == 'D' ? 1 : 0;
    // ver_sw is the repository's commit when the run started (`git describe`), which a commit between two runs of
    // one build changes: the build's, not the run's.
    if (ma[i].type == 'I' && ma[i].payload.find(" ver_sw") != std::string::npos &&
        mb[i].payload.find(" ver_sw") != std::string::npos) {
      continue;
    }
    if (machine_log_line(ma[i]) && machine_log_line(mb[i])) {
      ++machine;
      EXPECT_EQ(ma[i].payload.substr(0, 9), mb[i].payload.substr(0, 9)) << "message " << i << " (level, timestamp)";
      continue;
    }
    EXPECT_TRUE(ma[i].payload == mb[i].payload)
        << "message " << i << " (type " << ma[i].type << ", " << ma[i].payload.size() << " bytes) differs";
  }
  EXPECT_GT(data, 1000U);
  EXPECT_LT(machine, ma.size() / 10) << "most of the log exempted as the machine's";
}

TEST_F(Determinism, TwoFlightsWithOneSeed_IdenticalUlogsButForMachineLines) {
  const Flight a = fly("a", "6", {"--ulog", (dir_ / "a.ulg").string()});
  const Flight b = fly("b", "6", {"--ulog", (dir_ / "b.ulg").string()});
  ASSERT_EQ(a.outcome.exit_code, 0) << a.outcome.err;
  ASSERT_EQ(b.outcome.exit_code, 0) << b.outcome.err;
  expect_same_ulog(dir_ / "a.ulg", dir_ / "b.ulg");
}

// Two runs at once on ONE DDS domain (docs/protocol.md "One run, one partition"): each kernel puts its bridge and
// its plant in its run's own partition, so each flies its own plant from the first step: both finish the
// mission, and each writes the trace, summary and ULog that the seed writes in a run alone. The control: the
// same two runs given one run id (so one partition, shared) hear each other's plant,
// and not both fly the lone run's flight (a kernel refuses the other plant's steps: StopReason::PlantProtocol).
TEST_F(Determinism, TwoRunsAtOnceOnOneDomain_EachFliesItsOwnPlant) {
  square_ = "quad_square.launch.pbtxt";
  const auto ulog = [&](const std::string& name) { return std::vector<std::string>{"--ulog", (dir_ / (name + ".ulg")).string()}; };
  const Flight alone = fly("alone", "", ulog("alone"));
  ASSERT_EQ(alone.outcome.exit_code, 0) << alone.outcome.err;
  ASSERT_TRUE(alone.summary.mission_completed()) << alone.outcome.out;
  const Started b = start("b", "", ulog("b"));
  const Started c = start("c", "", ulog("c"));
  const Flight fb = finish(b);
  const Flight fc = finish(c);
  for (const Flight* f : {&fb, &fc}) {
    EXPECT_EQ(f->outcome.exit_code, 0) << f->outcome.err;
    EXPECT_TRUE(f->summary.mission_completed()) << f->outcome.out;
    EXPECT_NE(f->outcome.err.find("DDS partition rejuv."), std::string::npos) << f->outcome.err;
  }
  // The summaries name their own ULog files; everything else is the seed's.
  const auto ulog_unnamed = [](Flight f) {
    f.summary.mutable_ulog()->clear_path();
    return f;
  };
  expect_same_flight(ulog_unnamed(alone), ulog_unnamed(fb));
  expect_same_flight(ulog_unnamed(alone), ulog_unnamed(fc));
  expect_same_ulog(dir_ / "alone.ulg", dir_ / "b.ulg");
  expect_same_ulog(dir_ / "alone.ulg", dir_ / "c.ulg");
}

TEST_F(Determinism, TwoRunsAtOnceOnOneDomain_OneRunIdShared_TheyHearEachOther) {
  square_ = "quad_square.launch.pbtxt";
  const Flight alone = fly("alone", "6");
  ASSERT_EQ(alone.outcome.exit_code, 0) << alone.outcome.err;
  const std::vector<std::string> shared{"--run-id", "5ea5ed00c0ffee00"};
  const Started b = start("b", "6", shared);
  const Started c = start("c", "6", shared);
  // A run refused at boot writes no summary: its exit code and trace are what is compared.
  const auto flew_alone = [&](const Started& s) {
    const auto outcome = rejuv::test_support::wait_program(dir_ / s.name, s.pid);
    return std::pair{outcome.exit_code == 0 && slurp(dir_ / (s.name + ".csv")) == alone.csv, outcome.err};
  };
  const auto [b_alone, b_err] = flew_alone(b);
  const auto [c_alone, c_err] = flew_alone(c);
  EXPECT_FALSE(b_alone && c_alone) << b_err << "\n" << c_err;
}

// The estimate catch-up's replay (launch/quad_square) keeps the run deterministic: it is routed in the
// lockstep's canonical order with the graph idle between its instants, and charged by the model per sample.
TEST_F(Determinism, EstimateCatchUp_TwoFlightsWithOneSeed_IdenticalTracesAndSummaries) {
  square_ = "quad_square.launch.pbtxt";
  const Flight a = fly("a", "6");
  const Flight b = fly("b", "6");
  ASSERT_EQ(a.outcome.exit_code, 0) << a.outcome.err;
  ASSERT_EQ(b.outcome.exit_code, 0) << b.outcome.err;
  EXPECT_GT(a.summary.rollbacks(), 1U) << a.outcome.out;
  EXPECT_EQ(a.summary.catch_up().replays(), a.summary.rollbacks()) << a.outcome.out;
  EXPECT_GT(a.summary.catch_up().samples(), 0U);
  expect_same_flight(a, b);
}

// The catch-up in real time (no determinism to check there: the world goes on): the replay is handed on as fast
// as the chain takes it and ends when the chain answered the kernel's Sync; every rollback is caught up and the
// vehicle stays inside the safety set. No timing is asserted.
TEST_F(Determinism, EstimateCatchUp_InRealTime_EveryRollbackCaughtUp) {
  square_ = "quad_square.launch.pbtxt";
  const Flight a = fly("realtime", "6", {"--realtime"});
  ASSERT_EQ(a.outcome.exit_code, 0) << a.outcome.err;
  EXPECT_GT(a.summary.rollbacks(), 1U) << a.outcome.out;
  EXPECT_EQ(a.summary.catch_up().replays(), a.summary.rollbacks()) << a.outcome.out;
  EXPECT_EQ(a.summary.catch_up().without_log(), 0U);
  EXPECT_GT(a.summary.catch_up().samples(), 50 * a.summary.catch_up().replays());
  // What the chain publishes for the controllers during a replay is dropped by the kernel (catch_up.hpp); ekf2
  // itself holds its estimate until the replay is judged (ekf2_node.cpp), so whether anything is left to drop
  // depends on when the replay's last tick and the kernel's DONE meet: counted, not required. The property is
  // that every rollback was caught up (above) and the vehicle stayed inside the safety set (below).
  ::testing::Test::RecordProperty("catch_up_dropped", std::to_string(a.summary.catch_up().dropped()));
  EXPECT_EQ(a.summary.charging().charge(), "none");
  EXPECT_LT(a.summary.max_v(), 1.0);
}

// --speed paces lockstep for a ground station in wall-clock time: never faster than asked (a bound a loaded
// machine cannot break: pacing only waits), and the flight is the same, byte for byte.
TEST_F(Determinism, SpeedPaced_NoFasterThanAsked_SameTrace) {
  const Flight free_run = fly("free", "2");
  const Flight paced = fly("paced", "2", {"--speed", "4"});
  ASSERT_EQ(paced.outcome.exit_code, 0) << paced.outcome.err;
  // 2 s of alignment and 2 s of flight at 4x: at least 1 s of wall time.
  EXPECT_LE(paced.summary.realtime_factor(), 4.0 * 1.02) << paced.outcome.out;
  EXPECT_GE(paced.summary.wall_time_s(), paced.summary.sim_time_s() / (4.0 * 1.02));
  EXPECT_TRUE(paced.csv == free_run.csv) << "traces differ: diff " << (dir_ / "free.csv") << " " << (dir_ / "paced.csv");
}

TEST_F(Determinism, FlightShorterThanTest_NoCheckpointRollbackOrTimerBeforeTheCycle) {
  // 0.3 s of flight: less than T_est (0.5 s), so the first SR cycle has not reached its checkpoint. SR starts
  // with the flight (docs/design.md §6): nothing is checkpointed, rolled back or armed during the alignment.
  const Flight f = fly("short", "0.3");
  ASSERT_EQ(f.outcome.exit_code, 0) << f.outcome.err;
  EXPECT_EQ(f.summary.checkpoints(), 0U) << f.outcome.out;
  EXPECT_EQ(f.summary.rollbacks(), 0U) << f.outcome.out;
  EXPECT_EQ(f.summary.attacks(), 0U) << f.outcome.out;  // no MC window: no rejuvenation timer armed
  EXPECT_EQ(f.summary.image_phases().images_by_fork(), 0U);
  EXPECT_EQ(f.summary.image_phases().images_by_pages(), 0U);
  // The alignment's images (one per rejuvenated service, by fork) are made, but not counted as the flight's.
  EXPECT_EQ(f.summary.charging().priming_images(), kRejuvenated);
  EXPECT_DOUBLE_EQ(f.summary.charging().alignment_s(), 2.0);
  EXPECT_DOUBLE_EQ(f.summary.charging().charged_s(), 0.0);
  // Every row of the trace: the setpoint is still the first waypoint (0, 0, -3), the mode SC.
  std::istringstream rows(f.csv);
  std::string row;
  std::getline(rows, row);  // the header
  std::size_t n = 0;
  while (std::getline(rows, row)) {
    ++n;
    EXPECT_NE(row.find(",0,0,-3,0,SC,"), std::string::npos) << "row " << n << ": " << row;
    if (HasFailure()) break;
  }
  EXPECT_GT(n, 10U);
}

}  // namespace
