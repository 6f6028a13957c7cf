// `rejuv faults --realtime --load cpu:N` (docs/design.md §11): the fault campaign flown in real time with the
// graph's real-time plan beside a companion-like background load. The real binary on the shipped square: a short
// campaign judged by the campaign's verdicts, each recovery's real duration recorded; the load's workers ended
// with the campaign on Ctrl-C and when the campaign itself is killed; bad --load values refused by name.
// No timing is asserted. The 200-fault campaign is the ctest label `long` (tests/multiproc/CMakeLists.txt).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "../proc_stat.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "faults.pb.h"
#include <google/protobuf/util/json_util.h>

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::kRejuv;
using rejuv::test_support::proc_stat;
using rejuv::test_support::slurp;

// The processes named `rejuv-load` (the load's workers) whose parent is `parent`.
std::vector<pid_t> load_workers_of(pid_t parent) {
  std::vector<pid_t> out;
  for (const auto& e : std::filesystem::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.empty() || name[0] < '0' || name[0] > '9') continue;
    if (slurp(e.path() / "comm") != "rejuv-load\n") continue;
    const auto pid = static_cast<pid_t>(std::stoi(name));
    if (proc_stat(pid).parent == parent) out.push_back(pid);
  }
  return out;
}

// Whether `pid` is still a load worker (alive and not a zombie; a reused pid is another program).
bool still_a_worker(pid_t pid) {
  if (slurp("/proc/" + std::to_string(pid) + "/comm") != "rejuv-load\n") return false;
  return proc_stat(pid).living();
}

class FaultsRealtime : public rejuv::test_support::ScratchDirTest {
 protected:
  FaultsRealtime() : ScratchDirTest("rejuv_faults_rt_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }  // job-0.log tells what happened

  std::vector<std::string> campaign(const std::vector<std::string>& extra) const {
    std::vector<std::string> args{"faults", (kRepo / "launch" / "quad_square.launch.pbtxt").string(), "--domain",
                                  std::to_string(rejuv::test_support::kOwnDdsDomain), "--out", dir_.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  // Starts a campaign with two load workers, waits for them, ends the campaign with `sig` and checks that
  // no worker is left within 10 s.
  void workers_end_with_the_campaign(int sig) {
    const pid_t pid = rejuv::test_support::start_program(
        dir_, kRejuv, campaign({"--load", "cpu:2", "--injections", "6", "--per-mission", "6"}));
    ASSERT_GT(pid, 0);
    std::vector<pid_t> workers;
    for (int i = 0; i < 600 && workers.size() < 2; ++i) {  // the plan is the model's flight first: ≤ 60 s
      std::this_thread::sleep_for(std::chrono::milliseconds{100});
      workers = load_workers_of(pid);
    }
    ASSERT_EQ(workers.size(), 2U) << slurp(dir_ / "stderr");
    std::this_thread::sleep_for(std::chrono::seconds{2});  // the first mission is booting
    ASSERT_EQ(::kill(pid, sig), 0);
    const rejuv::test_support::CliOutcome r = rejuv::test_support::wait_program(dir_, pid);
    if (sig == SIGINT) {
      EXPECT_EQ(r.exit_code, 1) << r.err;  // interrupted: no table
    }
    bool left = true;
    for (int i = 0; i < 100 && left; ++i) {
      left = false;
      for (const pid_t w : workers) left = left || still_a_worker(w);
      if (left) std::this_thread::sleep_for(std::chrono::milliseconds{100});
    }
    for (const pid_t w : workers) EXPECT_FALSE(still_a_worker(w)) << "load worker " << w << " outlived the campaign";
  }
};

// One mission of three faults in real time beside one load worker: the campaign's verdicts (every injected fault
// recovered, nothing unsafe, leaked or hung: exit 0), the JSON says how it was flown, and every fault whose
// recovery went through a rollback or a cold restart has that recovery's real duration.
TEST_F(FaultsRealtime, ShortCampaignUnderLoad_JudgedAndEachRecoveryTimed) {
  const auto r = rejuv::test_support::run_rejuv(
      dir_, campaign({"--realtime", "--load", "cpu:1", "--injections", "3", "--per-mission", "3", "--seed", "7"}));
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("flown in real time with the graph's real-time plan, beside --load cpu:1"), std::string::npos)
      << r.out;
  rejuv::proto::FaultCampaign c;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(dir_ / "faults.json"), &c).ok());
  EXPECT_TRUE(c.realtime());
  EXPECT_EQ(c.load(), "cpu:1");
  std::size_t injected = 0;
  for (const rejuv::proto::FaultInjection& i : c.injections()) {
    if (!i.injected()) continue;
    ++injected;
    EXPECT_TRUE(i.recovered()) << i.ShortDebugString();
    if (i.path() == "rollback" || i.path() == "cold restart" || i.path().rfind("fallback", 0) == 0) {
      EXPECT_GT(i.recovery_ms(), 0) << i.ShortDebugString();
    }
  }
  EXPECT_GE(injected, 1U) << r.out;
  // The kernel's log says the real-time plan was applied.
  const std::string log = slurp(dir_ / "job-0.log");
  EXPECT_NE(log.find("real-time plan: kernel SCHED_FIFO"), std::string::npos);
  // Nothing of this graph forks, and the faults only kill or stop: a process "left behind" would be the
  // kernel's own, reported as a service's violation (a fallback retires the services again while the
  // incarnation the rollback retired is still in its live leaf; seed 7's kill-image at the checkpoint falls
  // back twice).
  EXPECT_EQ(log.find("left a process behind"), std::string::npos) << log;
}

TEST_F(FaultsRealtime, CtrlC_EndsTheLoadWorkers) { workers_end_with_the_campaign(SIGINT); }

// Killed outright, the campaign cannot stop them: each worker dies with it (PR_SET_PDEATHSIG).
TEST_F(FaultsRealtime, KilledCampaign_TakesTheLoadWorkersWithIt) { workers_end_with_the_campaign(SIGKILL); }

TEST_F(FaultsRealtime, BadLoadAndChargeInRealTime_RefusedAsUsage) {
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--load", "gpu:2"}, {"--load", "cpu:0"}, {"--load", "cpu:x"},
        {"--realtime", "--charge", "model"}}) {
    const auto r = rejuv::test_support::run_rejuv(dir_, campaign(extra));
    EXPECT_EQ(r.exit_code, 2) << extra.front() << " " << extra.back() << ": " << r.err;
    EXPECT_NE(r.err.find(extra.front() == "--load" ? "--load" : "--charge"), std::string::npos) << r.err;
  }
}

}  // namespace
