// Containment in a whole mission (docs/design.md §7 "Protection (containment)", §11): the square of
// launch/quad_square_paper.launch.pbtxt flown through the real kernel, the real flight services and the plant, with
// the worst-case control attack of §VI-D and, on top of it, a compromised ekf2 that forks a helper at boot
// (attack ESCAPE_HELPER, services/attacks) which tries, for as long as it lives, to send UDP to a listener
// this test owns and to set up an io_uring. A rollback erases only what is inside an image; a process is
// not, so the kernel must remove it: the forbidden call ends the helper, the sweep reaps it.
//
// Asserted by effect, no timing: no datagram reaches the listener; the kernel counted the helper (a forbidden
// call by name, or a stray); the helper is gone when the first rollback has happened; the mission completes
// inside the safety set; after the run no process of ekf2's session exists and the kernel (this process)
// has no child left. A service or the plant that is not built fails it.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "graph_fixture.hpp"
#include "mission_support.hpp"
#include "rejuv/sys/udp.hpp"
#include "run_recorder.hpp"
#include "run_summary.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using kernel::Kernel;
using kernel::StopReason;
using mission::missing_executable;
using mission::read_text;
using mission::RunLog;
using mission::session_members;
using mission::SessionGuard;


// quad_square_paper's text with ekf2 compromised: its escape_port param and an ESCAPE_HELPER entry in the plan,
// next to the worst-case control attack the graph already has. Empty when the graph no longer reads as
// expected (the caller fails).
std::string compromised_square(std::uint16_t port) {
  std::string t = read_text(fs::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt");
  const std::string ekf2 = "name: \"ekf2\"\n  executable: \"rejuv_ekf2\"\n";
  const std::string control_attack = "attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }";
  const std::size_t at_ekf2 = t.find(ekf2);
  if (at_ekf2 == std::string::npos) return {};
  t.insert(at_ekf2 + ekf2.size(), "  params { name: \"escape_port\" number: " + std::to_string(port) + " }\n");
  const std::size_t at_attack = t.find(control_attack);
  if (at_attack == std::string::npos) return {};
  t.insert(at_attack + control_attack.size(), "\n  attacks { kind: ESCAPE_HELPER service: \"ekf2\" }");
  return t;
}

// True when `pid` no longer names a process of session `sid` (gone, or the number reused elsewhere).
bool gone_from_session(pid_t pid, pid_t sid) { return ::getsid(pid) != sid; }

// The helper's pid from ekf2's report of the attempt ("helper pid N"; services/attacks hooks.cpp).
std::optional<pid_t> helper_pid(const RunLog& log) {
  const std::string t = log.text();
  static constexpr std::string_view kMark = "attack ESCAPE_HELPER: helper pid ";
  const std::size_t at = t.find(kMark);
  if (at == std::string::npos) return std::nullopt;
  pid_t pid = 0;
  const char* begin = t.data() + at + kMark.size();
  if (std::from_chars(begin, t.data() + t.size(), pid).ec != std::errc{} || pid <= 0) return std::nullopt;
  return pid;
}

// What the test saw during the run. Forwards everything to `rejuv run`'s recorder.
class Watch final : public kernel::Observer {
 public:
  Watch(kernel::Observer& inner, const sys::UdpSocket& listener, const RunLog& log, SessionGuard& guard)
      : inner_(inner), listener_(listener), log_(log), guard_(guard) {}
  void attach(Kernel* k) { kernel_ = k; }

  void on_publication(const kernel::Publication& p) override { inner_.on_publication(p); }
  void on_step(std::uint64_t step, Nanos t, SrMode mode) override {
    inner_.on_step(step, t, mode);
    drain();
    if (sid || kernel_ == nullptr) return;
    const auto id = kernel_->find_service("ekf2");
    if (!id) return;
    const int pid = kernel_->stats(*id).pid;
    if (pid <= 0) return;
    const pid_t s = ::getsid(pid);
    if (s <= 0) return;
    sid = s;
    guard_.watch(s);
  }
  void on_checkpoint(Generation g, const broker::Broker& q) override { inner_.on_checkpoint(g, q); }
  void on_restore(Generation g, const broker::Broker& q) override {
    inner_.on_restore(g, q);
    if (at_first_rollback || kernel_ == nullptr) return;
    // The first rollback: the queues are back at g, nothing has run since.
    FirstRollback seen;
    seen.helper = helper_pid(log_);
    if (seen.helper && sid) seen.helper_gone = gone_from_session(*seen.helper, *sid);
    if (const auto id = kernel_->find_service("ekf2")) seen.ekf2 = kernel_->stats(*id);
    at_first_rollback = std::move(seen);
  }
  // Datagrams that reached the listener so far.
  std::uint64_t drain() {
    std::array<std::byte, 2048> buf{};
    while (listener_.valid()) {
      auto got = listener_.receive(buf);
      if (!got) break;  // EAGAIN: nothing queued
      ++datagrams;
      if (senders.size() < 8) senders.push_back(got->from.to_string() + " (" + std::to_string(got->datagram_size) + " B)");
    }
    return datagrams;
  }

  struct FirstRollback {
    std::optional<pid_t> helper{};
    bool helper_gone = false;
    kernel::ServiceStats ekf2{};
  };
  std::optional<pid_t> sid{};
  std::optional<FirstRollback> at_first_rollback{};
  std::uint64_t datagrams = 0;
  std::vector<std::string> senders{};  // where the first datagrams came from, for the failure message

 private:
  kernel::Observer& inner_;
  const sys::UdpSocket& listener_;
  const RunLog& log_;
  SessionGuard& guard_;
  Kernel* kernel_ = nullptr;
};

bool refused(const kernel::ServiceStats& s, std::string_view call) {
  return std::any_of(s.calls_refused.begin(), s.calls_refused.end(),
                     [&](const auto& c) { return c.first == call && c.second > 0; });
}

TEST(CompromisedMission, Ekf2ForksANetworkHelperAtBoot_NoDatagramHelperGoneByFirstRollbackSafeNothingLeft) {
  // Given a UDP listener on 127.0.0.1 that the helper is told to reach.
  auto listener = sys::UdpSocket::bind(sys::UdpAddress::loopback(0), sys::Blocking::No);
  ASSERT_TRUE(listener.has_value()) << listener.error().to_string();
  auto bound = listener->local_address();
  ASSERT_TRUE(bound.has_value()) << bound.error().to_string();
  const std::uint16_t port = bound->port;
  const std::string text = compromised_square(port);
  ASSERT_FALSE(text.empty()) << "launch/quad_square_paper.launch.pbtxt no longer has ekf2 or the control attack";
  auto graph = launch::parse_launch(text, fs::path(REJUV_SOURCE_DIR) / "launch/quad_square_paper.launch.pbtxt");
  ASSERT_TRUE(graph.has_value()) << graph.error().to_string();
  if (const auto missing = missing_executable(*graph)) FAIL() << "not built: " << missing->string();
  auto reference = cli::run_reference(*graph, std::nullopt);
  ASSERT_TRUE(reference.has_value()) << reference.error();

  RunLog log;
  ASSERT_NE(log.get(), nullptr);
  const kernel::KernelOptions options = mission::mission_options(log.get());
  const int children_before = Resources::now().children;

  SessionGuard guard;  // declared before the kernel: runs after its destructor
  cli::RunRecorder recorder(std::move(*reference), nullptr, cli::RunRecorder::Progress::Off);
  Watch watch(recorder, *listener, log, guard);
  auto k = Kernel::create(std::move(*graph), options, &watch);
  ASSERT_TRUE(k.has_value()) << k.error().to_string();
  watch.attach(k->get());
  recorder.on_vehicle_lost([kernel = k->get()] { (*kernel).request_stop(); });

  // When the whole square is flown.
  auto outcome = (*k)->run();
  ASSERT_TRUE(outcome.has_value()) << outcome.error().to_string() << "\n" << log.lines_with("ekf2");
  proto::RunSummary summary;
  cli::fill_summary(summary, **k, recorder, *outcome, cli::facts_of(**k, options));
  const auto ekf2 = (*k)->find_service("ekf2");
  ASSERT_TRUE(ekf2.has_value());
  const kernel::ServiceStats stats = (*k)->stats(*ekf2);
  ::testing::Test::RecordProperty("max_V", std::to_string(summary.max_v()));
  ::testing::Test::RecordProperty("rollbacks", std::to_string((*k)->sr_stats().rollbacks));
  ::testing::Test::RecordProperty("ekf2_forbidden_calls", std::to_string(stats.forbidden_calls));
  ::testing::Test::RecordProperty("ekf2_stray_processes", std::to_string(stats.stray_processes));

  // Then no datagram arrived.
  EXPECT_EQ(watch.drain(), 0U) << "the helper reached the network; from " << ::testing::PrintToString(watch.senders)
                                << ", helper " << (helper_pid(log) ? std::to_string(*helper_pid(log)) : "unreported");

  // The kernel saw the helper and refused its network calls by name.
  const auto helper = helper_pid(log);
  ASSERT_TRUE(helper.has_value()) << "ekf2 did not report its helper:\n" << log.lines_with("ekf2");
  EXPECT_GE(stats.forbidden_calls + stats.stray_processes, 1U);
  EXPECT_TRUE(refused(stats, "socket") || refused(stats, "io_uring_setup"))
      << "calls refused: " << ::testing::PrintToString(stats.calls_refused) << "\n" << log.lines_with("ekf2");

  // The helper was gone when the first rollback had happened, and was already counted then.
  ASSERT_TRUE(watch.sid.has_value()) << "ekf2's session was never seen";
  ASSERT_TRUE(watch.at_first_rollback.has_value()) << "no rollback happened";
  const Watch::FirstRollback& first = *watch.at_first_rollback;
  ASSERT_TRUE(first.helper.has_value()) << "the helper's report was not logged by the first rollback";
  EXPECT_EQ(*first.helper, *helper);
  EXPECT_TRUE(first.helper_gone) << "helper pid " << *helper << " still in ekf2's session at the first rollback";
  EXPECT_GE(first.ekf2.forbidden_calls + first.ekf2.stray_processes, 1U);

  // The mission completed inside the safety set.
  EXPECT_EQ(outcome->reason, StopReason::MissionDone) << outcome->detail;
  EXPECT_TRUE(summary.mission_completed());
  EXPECT_FALSE(recorder.lost().has_value());
  EXPECT_LT(summary.max_v(), 1.0);
  EXPECT_FALSE(summary.left_safety_set());
  EXPECT_GT((*k)->sr_stats().rollbacks, 0U);
  EXPECT_EQ((*k)->sr_stats().cold_restarts, 0U);

  // And nothing is left after the run: no process of ekf2's session, no child of the kernel (this process).
  EXPECT_EQ(session_members(*watch.sid), std::vector<pid_t>{}) << "left in ekf2's session";
  EXPECT_EQ(Resources::now().children, children_before);
  k->reset();
  EXPECT_EQ(session_members(*watch.sid), std::vector<pid_t>{});
  EXPECT_EQ(Resources::now().children, 0);
}

}  // namespace
}  // namespace rejuv::testing
