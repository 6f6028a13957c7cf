// The LinkGuard built alone (kernel_sim/kernel/src/link_guard.hpp): handed hosts, a log and where a link
// service's cgroup is, as the kernel hands them, it closes and opens the links at the mode changes the kernel
// reports. Shown by effect on a real cgroup v2 group with a process in it (root; skipped otherwise): frozen at
// MC → RB, thawed at CP → MC and after a failed change, never before the service started; and by what it logs
// where a link cannot be closed. The nftables table of a host in a namespace is tested in a kernel run
// (tests/across_hosts/link_closure_run_test.cpp) and as sys::LinkClosure (tests/unit/sys/link_closure_test.cpp).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../../cgroup_v2_group.hpp"
#include "link_guard.hpp"

namespace rejuv::kernel {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// What the guard logged, and the cgroup it is told its link service has.
struct Guarded {
  std::vector<std::string> lines;
  LinkCgroup cgroup{.started = false, .dir = std::nullopt, .note = ""};
  LinkGuard guard{[this](const std::string& line) { lines.push_back(line); }, [this](ServiceId) { return cgroup; }};

  [[nodiscard]] bool said(const std::string& part) const {
    for (const std::string& l : lines) {
      if (l.find(part) != std::string::npos) return true;
    }
    return false;
  }
  [[nodiscard]] std::string all() const {
    std::string out;
    for (const std::string& l : lines) out += l + "\n";
    return out;
  }
};

LinkHost vehicle(std::string netns, std::vector<LinkService> services) {
  return LinkHost{.name = "vehicle", .netns = std::move(netns), .link_services = std::move(services)};
}

TEST(LinkGuard, OwnNamespaceWithoutLinkService_SaysItStaysOpen_ModeChangesDoNothing) {
  Guarded k;
  const std::vector<LinkHost> hosts{vehicle("", {})};
  k.guard.create(hosts, SrMode::SC);
  EXPECT_TRUE(k.said("link vehicle: its uplink is in the kernel's own network namespace (hosts.netns unset)"))
      << k.all();
  EXPECT_TRUE(k.said("and no link service to freeze: it stays open in the secure interval")) << k.all();
  const std::size_t before = k.lines.size();
  k.guard.before_mode(SrMode::MC, SrMode::RB);
  k.guard.after_mode(SrMode::MC, SrMode::RB, true);
  EXPECT_EQ(k.lines.size(), before) << k.all();
}

TEST(LinkGuard, NamespaceThatDoesNotExist_SaysItCannotBeClosed) {
  Guarded k;
  const std::vector<LinkHost> hosts{vehicle("rjN_absent_" + std::to_string(::getpid()), {})};
  k.guard.create(hosts, SrMode::MC);
  EXPECT_TRUE(k.said("link vehicle: cannot be closed in the secure interval: ")) << k.all();
  EXPECT_EQ(k.lines.size(), 1U) << k.all();
}

TEST(LinkGuard, LinkServiceWithoutCgroup_TheCloseSaysWhy_NothingBeforeItStarted) {
  Guarded k;
  const std::vector<LinkHost> hosts{vehicle("", {LinkService{.id = ServiceId{4}, .name = "link_companion"}})};
  k.guard.create(hosts, SrMode::SC);  // not started: nothing to freeze, nothing said about the start
  EXPECT_TRUE(k.said("closed in the secure interval by freezing link_companion's cgroup")) << k.all();
  EXPECT_EQ(k.lines.size(), 1U) << k.all();  // how it is closed; no close at the start
  k.cgroup = LinkCgroup{.started = true, .dir = std::nullopt, .note = "no cgroup v2 on this machine"};
  k.guard.before_mode(SrMode::MC, SrMode::RB);
  EXPECT_TRUE(k.said("link vehicle: link_companion's cgroup cannot be frozen at MC → RB: ")) << k.all();
  EXPECT_TRUE(k.said("no cgroup v2 on this machine")) << k.all();
}

// A cgroup v2 group of this test's own with one process that only waits.
class LinkGuardFreeze : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root: a cgroup of its own";
    std::string why;
    const auto group = rejuv::test_support::make_own_cgroup_v2_group("rjN_guard_" + std::to_string(::getpid()), why);
    if (!group) GTEST_SKIP() << why;
    group_ = *group;
    child_ = ::fork();
    ASSERT_GE(child_, 0);
    if (child_ == 0) {
      const int procs = ::open((group_ / "cgroup.procs").c_str(), O_WRONLY);
      if (procs < 0 || ::write(procs, "0", 1) != 1) ::_exit(3);
      for (;;) ::pause();
    }
    ASSERT_TRUE(wait_for([&] { return slurp(group_ / "cgroup.procs").find(std::to_string(child_)) != std::string::npos; }));
  }
  void TearDown() override {
    if (child_ > 0) {
      ::kill(child_, SIGKILL);
      int status = 0;
      ::waitpid(child_, &status, 0);
    }
    if (!group_.empty()) ::rmdir(group_.c_str());
  }
  static bool wait_for(const std::function<bool()>& done) {
    for (int i = 0; i < 2000; ++i) {
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return done();
  }
  [[nodiscard]] bool frozen() const {
    return wait_for([&] { return slurp(group_ / "cgroup.events").find("frozen 1") != std::string::npos; });
  }
  [[nodiscard]] bool thawed() const {
    return wait_for([&] { return slurp(group_ / "cgroup.events").find("frozen 0") != std::string::npos; });
  }
  fs::path group_;
  pid_t child_ = -1;
};

TEST_F(LinkGuardFreeze, OwnNamespace_FrozenAtMcToRb_ThawedAtCpToMc_AndAfterAFailedChange) {
  Guarded k;
  const std::vector<LinkHost> hosts{vehicle("", {LinkService{.id = ServiceId{4}, .name = "link_companion"}})};
  k.guard.create(hosts, SrMode::SC);
  // The kernel's start: the link service is spawned after create; the first MC opens nothing (it is open).
  k.cgroup = LinkCgroup{.started = true, .dir = group_, .note = ""};
  k.guard.before_mode(SrMode::CP, SrMode::MC);
  k.guard.after_mode(SrMode::CP, SrMode::MC, true);
  EXPECT_TRUE(thawed()) << slurp(group_ / "cgroup.events");
  EXPECT_FALSE(k.said(" opened at ")) << k.all();

  k.guard.before_mode(SrMode::MC, SrMode::RB);  // closed before the rights change
  EXPECT_TRUE(frozen()) << slurp(group_ / "cgroup.events");
  k.guard.after_mode(SrMode::MC, SrMode::RB, true);
  k.guard.before_mode(SrMode::RB, SrMode::SC);  // within the secure interval: stays closed
  k.guard.after_mode(SrMode::RB, SrMode::SC, true);
  EXPECT_TRUE(frozen()) << slurp(group_ / "cgroup.events");
  k.guard.before_mode(SrMode::CP, SrMode::MC);
  k.guard.after_mode(SrMode::CP, SrMode::MC, true);  // opened after the rights are back
  EXPECT_TRUE(thawed()) << slurp(group_ / "cgroup.events");
  EXPECT_TRUE(k.said("link vehicle closed at MC → RB (")) << k.all();
  EXPECT_TRUE(k.said("link vehicle opened at CP → MC (")) << k.all();

  k.guard.before_mode(SrMode::MC, SrMode::RB);
  EXPECT_TRUE(frozen()) << slurp(group_ / "cgroup.events");
  k.guard.after_mode(SrMode::MC, SrMode::RB, false);  // the change failed: the close is undone
  EXPECT_TRUE(thawed()) << slurp(group_ / "cgroup.events");
  EXPECT_TRUE(k.said("link vehicle opened at MC → RB (")) << k.all();
}

}  // namespace
}  // namespace rejuv::kernel
