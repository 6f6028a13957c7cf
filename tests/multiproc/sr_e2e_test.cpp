// End-to-end tests of software rejuvenation on the multi-process runtime (docs/design.md §7–§9, §11; paper §VI-D):
// the real kernel, the real flight services, checkpoint_p and the image store, the plant process over DDS, in
// lockstep with the plant as time master (Kernel::run, TimeMaster::Plant). The metrics are `rejuv run`'s own
// (its RunRecorder, rejuv_run_metrics), against the same path and safety ellipsoid as `rejuv sim`.
// A service or the plant that is not built fails the test (the build makes them all).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "graph_fixture.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/mavlink/mission.hpp"
#include "rejuv/sys/udp.hpp"
#include "run_recorder.hpp"
#include "run_summary.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using kernel::Kernel;
using kernel::StopReason;

// §VI-D: "at least 45 attacks" over the square (the model: 72 attacked windows and 72 rollbacks, seed 1).
constexpr std::uint64_t kMinAttacks = 45;

// What the ground station of a GroundUpload (below) saw.
struct GroundReport {
  std::optional<mavlink::MissionResult> result{};  // how the upload ended (MISSION_ACK)
  std::uint32_t restarts = 0;                     // uploads started again after the vehicle lost one
  std::vector<std::string> texts{};               // STATUSTEXTs received
  std::uint64_t transmissions = 0;
  std::uint64_t mission_upload_published = 0;  // publications on commander's mission_upload topic
  std::optional<std::uint64_t> rollbacks_when_off_path{};  // rollbacks before a setpoint first left the launch path
  std::optional<std::uint64_t> rollbacks_when_at_upload{};  // … when it first reached the upload's last waypoint
  std::uint64_t rollbacks = 0;
  std::array<double, 3> last_setpoint{};
  bool last_setpoint_done = false;
  double max_off_path_m = 0;  // the farthest a setpoint was from the launch graph's first leg
};

struct Mission {
  proto::RunSummary summary;  // as `rejuv run` fills it (cli::fill_summary)
  kernel::RunOutcome outcome;
  kernel::SrStats sr;
  kernel::CatchUpStats catch_up;
  std::uint64_t mc_windows = 0;  // epochs in which the kernel published mode MC
  std::size_t killed = 0;        // processes a KillGroup killed
  bool lost = false;             // the recorder declared the vehicle lost (V > 100) and stopped the run
  Nanos alignment{0};
  GroundReport ground{};         // with a GroundUpload
};

// The first executable of the graph (a service or the plant) that is not built, if any.
std::optional<fs::path> missing_executable(const launch::LoadedLaunch& g) {
  for (const proto::ServiceSpec& s : g.graph.services()) {
    if (!fs::exists(kServiceDir / s.executable())) return kServiceDir / s.executable();
  }
  if (!fs::exists(kServiceDir / g.graph.plant().executable()))
    return kServiceDir / g.graph.plant().executable();
  return std::nullopt;
}

enum class Sr : std::uint8_t { On, Off };
enum class Attack : std::uint8_t { On, Off };
enum class Path : std::uint8_t { Square, FirstLeg };  // FirstLeg: only the first 1 m side of the square

// A fault: at the first lockstep step at or after `after` (flight time, past the alignment) every process of
// `service` — the live one and every frozen image — is killed. No generation is left to roll back to, so the
// kernel must cold-restart the graph (docs/design.md §7 "Faults", "Cold restart").
struct KillGroup {
  std::string service;
  Nanos after{0};
};

// Forwards everything to `rejuv run`'s recorder and carries out a KillGroup.
class FaultInjector final : public kernel::Observer {
 public:
  FaultInjector(kernel::Observer& inner, KillGroup fault, Nanos alignment)
      : inner_(inner), fault_(std::move(fault)), at_(alignment + fault_.after) {}
  void attach(Kernel* k) { kernel_ = k; }
  [[nodiscard]] std::size_t killed() const { return killed_; }

  void on_publication(const kernel::Publication& p) override { inner_.on_publication(p); }
  void on_step(std::uint64_t step, Nanos t, SrMode mode) override {
    inner_.on_step(step, t, mode);
    if (done_ || kernel_ == nullptr || t < at_) return;
    done_ = true;
    const auto id = kernel_->find_service(fault_.service);
    if (!id) return;
    std::vector<int> pids = kernel_->image_pids(*id);
    pids.push_back(kernel_->stats(*id).pid);
    for (const int pid : pids) {
      if (pid > 0 && ::kill(pid, SIGKILL) == 0) ++killed_;
    }
  }
  void on_checkpoint(Generation g, const broker::Broker& q) override { inner_.on_checkpoint(g, q); }
  void on_restore(Generation g, const broker::Broker& q) override { inner_.on_restore(g, q); }

 private:
  kernel::Observer& inner_;
  KillGroup fault_;
  Nanos at_;
  Kernel* kernel_ = nullptr;
  bool done_ = false;
  std::size_t killed_ = 0;
};

// The ground station (MAVLink 2, docs/mavlink.md) played from the kernel's loop: from `after` (flight time) on
// it runs the mission upload protocol over UDP with the kernel's network gate, retransmitting its last
// message every 200 ms of kernel time without an answer (the gate drops everything in the secure execution
// interval, and a rollback may end the transaction in ext_link, which the vehicle then answers with
// MAV_MISSION_INVALID_SEQUENCE and the upload starts again — as `rejuv gcs` does). It watches the setpoints
// the vehicle flies and counts the rollbacks around them.
struct GroundUpload {
  std::vector<mavlink::LocalWaypoint> waypoints{};
  double acceptance_radius_m = 0.05;
  Nanos after{0};
};

class GroundStation final : public kernel::Observer {
 public:
  GroundStation(kernel::Observer& inner, GroundUpload spec, Nanos alignment)
      : inner_(inner),
        spec_(std::move(spec)),
        start_(alignment + spec_.after),
        uploader_(spec_.waypoints, spec_.acceptance_radius_m) {
    auto s = sys::UdpSocket::bind(sys::UdpAddress::loopback(0), sys::Blocking::No);
    EXPECT_TRUE(s.has_value());
    if (s) socket_ = std::move(*s);
  }
  void attach(Kernel* k) { kernel_ = k; }
  [[nodiscard]] const GroundReport& report() const { return report_; }

  void on_publication(const kernel::Publication& p) override {
    inner_.on_publication(p);
    if (p.name == "mission_upload") ++report_.mission_upload_published;
    if (p.name != "setpoint" || p.payload.size() != sizeof(rejuv_msg_Setpoint)) return;
    rejuv_msg_Setpoint sp{};
    std::memcpy(&sp, p.payload.data(), sizeof sp);
    report_.last_setpoint = {sp.p_N_m[0], sp.p_N_m[1], sp.p_N_m[2]};
    report_.last_setpoint_done = sp.mission_done != 0;
    // The launch graph's first leg: (0, 0, −3) → (1, 0, −3).
    const double off = std::hypot(sp.p_N_m[1], sp.p_N_m[2] + 3.0) + std::max(0.0, sp.p_N_m[0] - 1.0) +
                       std::max(0.0, -sp.p_N_m[0]);
    report_.max_off_path_m = std::max(report_.max_off_path_m, off);
    if (off > 1e-6 && !report_.rollbacks_when_off_path) report_.rollbacks_when_off_path = report_.rollbacks;
    const mavlink::LocalWaypoint& end = spec_.waypoints.back();
    const double to_end = std::hypot(sp.p_N_m[0] - end.north_m, sp.p_N_m[1] - end.east_m, sp.p_N_m[2] - end.down_m);
    if (to_end < 1e-6 && !report_.rollbacks_when_at_upload) report_.rollbacks_when_at_upload = report_.rollbacks;
  }
  void on_step(std::uint64_t step, Nanos t, SrMode mode) override {
    inner_.on_step(step, t, mode);
    if (kernel_ == nullptr || t < start_) return;
    const auto port = kernel_->network_port();
    if (!port) return;
    const auto send = [&](const mavlink::Message& m) {
      const mavlink::Frame f = mavlink::encode(m, mavlink::Envelope{.seq = seq_++, .sysid = 255, .compid = 190});
      if (socket_.send_to(f.view(), sys::UdpAddress::loopback(*port))) ++report_.transmissions;
      next_send_ = t + std::chrono::milliseconds{200};
    };
    std::array<std::byte, mavlink::kMaxFrameBytes + 1> buf{};
    for (;;) {
      auto r = socket_.receive(buf);
      if (!r) break;
      auto p = mavlink::decode(std::span<const std::byte>(buf.data(), r->size));
      if (!p) continue;
      if (const auto* text = std::get_if<mavlink::StatusText>(&p->message)) report_.texts.push_back(mavlink::text_of(*text));
      if (auto reply = uploader_.on_message(p->message)) send(*reply);
    }
    report_.restarts = uploader_.restarts();
    if (uploader_.status() != mavlink::MissionUploader::Status::InProgress) {
      report_.result = uploader_.result();
      return;
    }
    if (t < next_send_) return;
    send(started_ ? uploader_.last_sent() : uploader_.start());
    started_ = true;
  }
  void on_checkpoint(Generation g, const broker::Broker& q) override { inner_.on_checkpoint(g, q); }
  void on_restore(Generation g, const broker::Broker& q) override {
    inner_.on_restore(g, q);
    ++report_.rollbacks;
  }

 private:
  kernel::Observer& inner_;
  GroundUpload spec_;
  Nanos start_;
  mavlink::MissionUploader uploader_;
  bool started_ = false;
  std::uint8_t seq_ = 0;
  Nanos next_send_{0};
  sys::UdpSocket socket_;
  Kernel* kernel_ = nullptr;
  GroundReport report_{};
};

// The SR scheme flown: the paper's (launch/quad_square_paper), or the estimate catch-up's (launch/quad_square:
// T_est 50 ms, ρ_M 0.2), with its replay on or switched off in the same file.
enum class Scheme : std::uint8_t { Paper, CatchUp, CatchUpWithoutReplay };

// Flies the scheme's square (seed 1) as `rejuv run` does. nullopt: a failure, already reported (a missing
// executable among them); the caller asserts has_value().
std::optional<Mission> fly(Sr sr, Attack attack, Path path, std::optional<KillGroup> fault = std::nullopt,
                           std::optional<GroundUpload> ground = std::nullopt, Scheme scheme = Scheme::Paper) {
  auto graph = launch::load_launch(fs::path(REJUV_SOURCE_DIR) /
                                   (scheme == Scheme::Paper ? "launch/quad_square_paper.launch.pbtxt"
                                                            : "launch/quad_square.launch.pbtxt"));
  if (!graph) {
    ADD_FAILURE() << graph.error().to_string();
    return std::nullopt;
  }
  if (scheme == Scheme::CatchUpWithoutReplay) graph->graph.mutable_sr()->set_estimate_catch_up(false);
  if (const auto missing = missing_executable(*graph)) {
    ADD_FAILURE() << "not built: " << missing->string();
    return std::nullopt;
  }
  if (path == Path::FirstLeg) {
    auto* waypoints = graph->graph.mutable_mission()->mutable_waypoints();
    waypoints->DeleteSubrange(2, waypoints->size() - 2);
  }
  auto reference = cli::run_reference(*graph, std::nullopt);
  if (!reference) {
    ADD_FAILURE() << reference.error();
    return std::nullopt;
  }
  kernel::KernelOptions options = test_options();
  options.time_master = kernel::TimeMaster::Plant;
  options.no_sr = sr == Sr::Off;
  options.no_attack = attack == Attack::Off;
  options.idle_deadline = std::chrono::seconds{10};
  options.network_port = 0;  // any free port: tests may run side by side
  Mission m;  // the plant aligns as long as the model (launch lockstep.alignment_s, passed by the kernel)
  m.alignment = reference->alignment;
  cli::RunRecorder recorder(std::move(*reference), nullptr, cli::RunRecorder::Progress::Off);
  std::optional<FaultInjector> injector;
  if (fault) injector.emplace(recorder, *fault, m.alignment);
  kernel::Observer* observer = injector ? static_cast<kernel::Observer*>(&*injector) : &recorder;
  std::optional<GroundStation> station;
  if (ground) {
    station.emplace(*observer, *ground, m.alignment);
    observer = &*station;
  }
  auto k = Kernel::create(std::move(*graph), options, observer);
  if (!k) {
    ADD_FAILURE() << k.error().to_string();
    return std::nullopt;
  }
  if (injector) injector->attach(k->get());
  if (station) station->attach(k->get());
  recorder.on_vehicle_lost([kernel = k->get()] { kernel->request_stop(); });
  auto outcome = (*k)->run();
  if (!outcome) {
    ADD_FAILURE() << outcome.error().to_string();
    return std::nullopt;
  }
  m.outcome = *outcome;
  cli::fill_summary(m.summary, **k, recorder, *outcome, cli::facts_of(**k, options));
  m.sr = (*k)->sr_stats();
  m.catch_up = (*k)->catch_up_stats();
  m.mc_windows = recorder.mc_windows();
  m.killed = injector ? injector->killed() : 0;
  m.lost = recorder.lost().has_value();
  if (station) m.ground = station->report();
  ::testing::Test::RecordProperty("max_V", std::to_string(m.summary.max_v()));
  ::testing::Test::RecordProperty("rollbacks", std::to_string(m.sr.rollbacks));
  ::testing::Test::RecordProperty("attacks", std::to_string(m.summary.attacks()));
  ::testing::Test::RecordProperty("mission_time_s", std::to_string(m.summary.mission_time_s()));
  ::testing::Test::RecordProperty("wall_time_s", std::to_string(to_seconds(outcome->wall_time).count()));
  return m;
}

// Fig. 8 cannot happen: checkpoint_p arms the rejuvenation timer once per epoch, before it enters MC
// (§V-A), the kernel refuses a second arm in an epoch, and every rollback is the timer's.
void expect_one_timer_arm_per_epoch(const Mission& m) {
  EXPECT_GT(m.sr.timer_arms, 0U);
  EXPECT_EQ(m.sr.timer_arms, m.mc_windows) << "every MC window opened by exactly one arm";
  EXPECT_EQ(m.sr.timer_arm_refused, 0U);
  EXPECT_EQ(m.sr.timer_rollbacks, m.sr.rollbacks);
  EXPECT_EQ(m.sr.cold_restarts, 0U);
}

// (a) and (d) on one mission (the whole square, ≈1 min of wall time): the paper's result — with SR, the
// worst-case attack in every MC window never pushes the vehicle out of the safety set — and the timer
// discipline that makes it hold.
TEST(SrEndToEnd, SrUnderAttack_CompletesTheSquareInsideTheSafetySet_OneTimerArmPerEpoch) {
  const auto m = fly(Sr::On, Attack::On, Path::Square);
  ASSERT_TRUE(m.has_value()) << "the mission did not fly (the failure is reported above)";
  EXPECT_EQ(m->outcome.reason, StopReason::MissionDone) << m->outcome.detail;
  EXPECT_TRUE(m->summary.mission_completed());
  EXPECT_FALSE(m->lost);
  EXPECT_GE(m->summary.attacks(), kMinAttacks);
  EXPECT_GE(m->sr.rollbacks, kMinAttacks);
  EXPECT_LT(m->summary.max_v(), 1.0);
  EXPECT_FALSE(m->summary.left_safety_set());
  expect_one_timer_arm_per_epoch(*m);
}

// SR's cost (docs/control.md §6.3): after every rollback the kernel replays the plant's samples since the
// restored generation's cut through the restored sensors → ekf2, so the estimate the controllers get next is as
// fresh as a never-attacked estimator's; T_est then shrinks to 50 ms and ρ_M doubles. Under the worst-case attack
// the square takes little more than without SR (simulated time, lockstep: deterministic), far inside the safety
// set, every rollback caught up. The same file with the replay switched off shows it is the replay that does it:
// the restored estimate is then a cycle old (est. error 0.51 against 0.024, max V 0.45 against 0.13, seed 1).
TEST(SrEndToEnd, EstimateCatchUp_UnderAttack_TheSquareAtLittleCost_EveryRollbackCaughtUp) {
  const auto with = fly(Sr::On, Attack::On, Path::Square, std::nullopt, std::nullopt, Scheme::CatchUp);
  const auto no_sr = fly(Sr::Off, Attack::Off, Path::Square, std::nullopt, std::nullopt, Scheme::CatchUp);
  const auto without = fly(Sr::On, Attack::On, Path::Square, std::nullopt, std::nullopt, Scheme::CatchUpWithoutReplay);
  ASSERT_TRUE(with && no_sr && without) << "a mission did not fly (the failure is reported above)";
  for (const Mission* m : {&*with, &*no_sr, &*without}) {
    EXPECT_EQ(m->outcome.reason, StopReason::MissionDone) << m->outcome.detail;
    EXPECT_TRUE(m->summary.mission_completed());
  }
  EXPECT_GE(with->summary.attacks(), 30U);
  EXPECT_LT(with->summary.max_v(), 0.4);
  EXPECT_LE(with->summary.mission_time_s(), 1.5 * no_sr->summary.mission_time_s());
  EXPECT_EQ(with->catch_up.replays, with->sr.rollbacks) << "every rollback caught up";
  EXPECT_EQ(with->catch_up.without_log, 0U);
  EXPECT_GT(with->catch_up.samples, 50 * with->catch_up.replays) << "a cycle's samples each time";
  EXPECT_GT(with->catch_up.dropped, 0U) << "the replay's estimates were held from the controllers";
  expect_one_timer_arm_per_epoch(*with);
  EXPECT_LT(with->summary.max_est_err_p(), 0.1);
  EXPECT_EQ(without->catch_up.replays, 0U);
  EXPECT_GT(without->summary.max_est_err_p(), 2 * with->summary.max_est_err_p());
  EXPECT_GT(without->summary.mission_time_s(), with->summary.mission_time_s());
}

// (b) Without SR the same attack drives the vehicle out of the safety set, and the run ends once it is lost
// (V > 100, as `rejuv sim`), long before the 59 s the square takes without attack.
TEST(SrEndToEnd, NoSrUnderAttack_LeavesTheSafetySetAndStopsWhenLost) {
  const auto m = fly(Sr::Off, Attack::On, Path::Square);
  ASSERT_TRUE(m.has_value()) << "the mission did not fly (the failure is reported above)";
  EXPECT_GT(m->summary.max_v(), 1.0);
  EXPECT_TRUE(m->summary.left_safety_set());
  EXPECT_TRUE(m->lost);
  EXPECT_EQ(m->outcome.reason, StopReason::Requested) << m->outcome.detail;
  EXPECT_FALSE(m->summary.mission_completed());
  EXPECT_LT(m->outcome.sim_time - m->alignment, std::chrono::seconds{30});  // simulated flight time
  EXPECT_EQ(m->summary.attacks(), 1U);  // one endless MC window, attacked from its start
  EXPECT_EQ(m->sr.rollbacks, 0U);
}

// (c) SR without attacks completes a mission: the first side of the square (1 m, ≈20 SR cycles) is as short
// as a mission that moves the setpoint across many cycles can be. The timer discipline holds here too.
TEST(SrEndToEnd, SrWithoutAttack_CompletesAOneMetreLegInsideTheSafetySet) {
  const auto m = fly(Sr::On, Attack::Off, Path::FirstLeg);
  ASSERT_TRUE(m.has_value()) << "the mission did not fly (the failure is reported above)";
  EXPECT_EQ(m->outcome.reason, StopReason::MissionDone) << m->outcome.detail;
  EXPECT_TRUE(m->summary.mission_completed());
  EXPECT_GT(m->sr.rollbacks, 0U);
  EXPECT_EQ(m->summary.attacks(), 0U);
  EXPECT_LT(m->summary.max_v(), 1.0);
  expect_one_timer_arm_per_epoch(*m);
}

// Item 2 of the fault report: a cold restart in the middle of the square (every process of gen_set_point
// killed 130 s into the ≈265 s flight, so that no generation can be restored) must not throw the vehicle out
// of the safety set. The restarted graph flies on from the kept mission state (x_sp, the waypoint) in SC with
// the network off, its estimator started from the sensors, and completes the mission. Without the kept state
// and the estimator's start from the sensors the same run reaches max V ≈ 2.35 (seed 1).
TEST(SrEndToEnd, ColdRestartMidSquare_StaysInsideTheSafetySetAndCompletesTheMission) {
  const auto m = fly(Sr::On, Attack::On, Path::Square,
                     KillGroup{.service = "gen_set_point", .after = std::chrono::seconds{130}});
  ASSERT_TRUE(m.has_value()) << "the mission did not fly (the failure is reported above)";
  ASSERT_GE(m->killed, 2U) << "the live gen_set_point and at least one image";
  EXPECT_EQ(m->sr.cold_restarts, 1U);
  EXPECT_EQ(m->outcome.reason, StopReason::MissionDone) << m->outcome.detail;
  EXPECT_TRUE(m->summary.mission_completed());
  EXPECT_FALSE(m->lost);
  EXPECT_LT(m->summary.max_v(), 1.0);
  EXPECT_FALSE(m->summary.left_safety_set());
}

// A mission uploaded over the ground link is flown, and survives the rollbacks that wipe
// everything else an MC window leaves behind (commander keeps it in the Persistent cell uploaded_mission,
// gen_set_point flies it from the next setpoint update and records it in mission_state). The vehicle flies
// the square's first leg north; 3 s in, the ground station uploads a 1 m leg west of it (inside the geofence).
// The setpoints leave the launch path for the uploaded waypoint, with rollbacks between the upload's
// application and its end, the mission completes there, and max V < 1.
TEST(SrEndToEnd, UploadedMission_FlownAcrossRollbacksToItsEnd) {
  GroundUpload ground;
  ground.waypoints = {{.north_m = 0, .east_m = -1, .down_m = -3, .yaw_rad = 0}};
  ground.after = std::chrono::seconds{3};
  const auto m = fly(Sr::On, Attack::Off, Path::FirstLeg, std::nullopt, ground);
  ASSERT_TRUE(m.has_value()) << "the mission did not fly (the failure is reported above)";
  const GroundReport& g = m->ground;
  ASSERT_TRUE(g.result.has_value()) << "no answer after " << g.transmissions << " transmissions";
  EXPECT_EQ(*g.result, mavlink::MissionResult::Accepted);
  // The vehicle reports its rollbacks in STATUSTEXT (queued in the SEI, sent in the next MC window).
  EXPECT_TRUE(std::any_of(g.texts.begin(), g.texts.end(), [](const std::string& t) { return t.starts_with("SR rollback"); }));
  EXPECT_GE(g.mission_upload_published, 1U);
  ASSERT_TRUE(g.rollbacks_when_off_path.has_value()) << "the setpoints never left the launch path";
  ASSERT_TRUE(g.rollbacks_when_at_upload.has_value()) << "the setpoints never reached the uploaded waypoint";
  EXPECT_GT(*g.rollbacks_when_at_upload, *g.rollbacks_when_off_path) << "no rollback while the upload was flown";
  EXPECT_NEAR(g.last_setpoint[0], 0.0, 1e-9);
  EXPECT_NEAR(g.last_setpoint[1], -1.0, 1e-9);
  EXPECT_NEAR(g.last_setpoint[2], -3.0, 1e-9);
  EXPECT_TRUE(g.last_setpoint_done);
  EXPECT_EQ(m->outcome.reason, StopReason::MissionDone) << m->outcome.detail;
  EXPECT_TRUE(m->summary.mission_completed());
  EXPECT_FALSE(m->lost);
  EXPECT_LT(m->summary.max_v(), 1.0);
  EXPECT_EQ(m->sr.cold_restarts, 0U);
  ::testing::Test::RecordProperty("rollbacks_flying_upload",
                                  std::to_string(*g.rollbacks_when_at_upload - *g.rollbacks_when_off_path));
}

// A refused upload (a waypoint 12 m east of home: outside the 10 m geofence) ends with MAV_MISSION_INVALID_PARAM5_X
// after a STATUSTEXT with the reason and the item, reaches nobody, and the launch graph's mission is flown unchanged.
TEST(SrEndToEnd, RefusedUpload_NegativelyAcknowledgedAndTheMissionFlownUnchanged) {
  GroundUpload ground;
  ground.waypoints = {{.north_m = 0.5, .east_m = 0.5, .down_m = -3, .yaw_rad = 0},
                      {.north_m = 0.5, .east_m = 12, .down_m = -3, .yaw_rad = 0}};
  ground.after = std::chrono::seconds{3};
  const auto m = fly(Sr::On, Attack::Off, Path::FirstLeg, std::nullopt, ground);
  ASSERT_TRUE(m.has_value()) << "the mission did not fly (the failure is reported above)";
  const GroundReport& g = m->ground;
  ASSERT_TRUE(g.result.has_value()) << "no answer after " << g.transmissions << " transmissions";
  EXPECT_EQ(*g.result, mavlink::MissionResult::InvalidParam5X);
  EXPECT_TRUE(std::find(g.texts.begin(), g.texts.end(), "mission refused: outside the geofence (item 1)") != g.texts.end());
  EXPECT_EQ(g.mission_upload_published, 0U);
  EXPECT_FALSE(g.rollbacks_when_off_path.has_value()) << "a setpoint left the launch path";
  EXPECT_LT(g.max_off_path_m, 1e-6);
  EXPECT_NEAR(g.last_setpoint[0], 1.0, 1e-9);  // the first leg's end
  EXPECT_NEAR(g.last_setpoint[1], 0.0, 1e-9);
  EXPECT_TRUE(g.last_setpoint_done);
  EXPECT_EQ(m->outcome.reason, StopReason::MissionDone) << m->outcome.detail;
  EXPECT_TRUE(m->summary.mission_completed());
  EXPECT_GT(m->sr.rollbacks, 0U);
  EXPECT_LT(m->summary.max_v(), 1.0);
}

}  // namespace
}  // namespace rejuv::testing
