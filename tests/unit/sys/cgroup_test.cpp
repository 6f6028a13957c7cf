// ServiceCgroup's two leaves (docs/sandbox.md "A cgroup per service"): a spawned process joins the live leaf,
// a process moved to the images leaf is out of reach of the live leaf's kill and of its OOM killer, and the
// live leaf's OOM kills are counted. Real cgroups: skipped where this process may not make one (no root).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>

#include "rejuv/sys/cgroup.hpp"

namespace rejuv::sys {
namespace {

using namespace std::chrono_literals;

bool contains(const std::vector<pid_t>& pids, pid_t pid) { return std::find(pids.begin(), pids.end(), pid) != pids.end(); }

// A child that joins the live leaf (as a spawned service does) and waits for a byte on `go`; on 'm' it
// touches `mb` MiB and answers a byte on `done`, on 'x' it exits.
pid_t joined_child(const ServiceCgroup& g, int go_read, int done_write, std::size_t mb) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  for (const int fd : g.join_fds()) {
    if (::write(fd, "0", 1) != 1) ::_exit(3);
  }
  for (char c = 0; ::read(go_read, &c, 1) == 1;) {
    if (c == 'x') ::_exit(0);
    const std::size_t n = mb << 20U;
    void* p = ::mmap(nullptr, n, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p != MAP_FAILED) std::memset(p, 1, n);
    if (::write(done_write, "d", 1) != 1) ::_exit(4);
  }
  ::_exit(0);
}

// Waits (bounded) until `pid` is listed in `leaf`.
bool listed_in(const ServiceCgroup& g, CgroupLeaf leaf, pid_t pid) {
  for (int i = 0; i < 2000; ++i) {
    if (contains(g.members(leaf), pid)) return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

class CgroupLeaves : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "making a cgroup needs root";
    auto made = ServiceCgroup::create("unit", "svc", CgroupLimits{.pids = 64, .memory_bytes = std::uint64_t{64} << 20U});
    if (!made) GTEST_SKIP() << "no cgroup here: " << made.error().to_string();
    group = std::move(*made);
  }
  void TearDown() override {
    for (const int fd : fds) ::close(fd);
    for (const pid_t pid : children) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
  }
  // A child with a pipe of its own: tell(pid, 'm') makes it touch its memory and waits for it to answer.
  pid_t child(std::size_t mb = 0) {
    int go[2] = {-1, -1};
    int done[2] = {-1, -1};
    if (::pipe(go) != 0 || ::pipe(done) != 0) return -1;
    fds.insert(fds.end(), {go[0], go[1], done[0], done[1]});
    const pid_t pid = joined_child(group, go[0], done[1], mb);
    if (pid > 0) {
      children.push_back(pid);
      tells.emplace_back(pid, std::pair{go[1], done[0]});
    }
    return pid;
  }
  bool tell(pid_t pid, char c, bool wait) {
    for (const auto& [p, ends] : tells) {
      if (p != pid) continue;
      if (::write(ends.first, &c, 1) != 1) return false;
      char answer = 0;
      return !wait || ::read(ends.second, &answer, 1) == 1;
    }
    return false;
  }
  ServiceCgroup group;
  std::vector<int> fds;
  std::vector<pid_t> children;
  std::vector<std::pair<pid_t, std::pair<int, int>>> tells;
};

TEST_F(CgroupLeaves, Join_SpawnedChild_InLiveLeaf) {
  const pid_t pid = child();
  ASSERT_GT(pid, 0);
  EXPECT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  EXPECT_FALSE(contains(group.members(CgroupLeaf::Images), pid));
}

TEST_F(CgroupLeaves, Move_ToImages_LeavesTheLiveLeaf) {
  const pid_t pid = child();
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  ASSERT_TRUE(group.move(pid, CgroupLeaf::Images).has_value());
  EXPECT_TRUE(contains(group.members(CgroupLeaf::Images), pid));
  EXPECT_FALSE(contains(group.members(CgroupLeaf::Live), pid));
}

TEST_F(CgroupLeaves, InLeaf_AfterMove_SaysWhere) {
  const pid_t pid = child();
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  if (group.description().find("cgroup v2") == std::string::npos) GTEST_SKIP() << "no cgroup v2 hierarchy here";
  EXPECT_TRUE(group.in_leaf(pid, CgroupLeaf::Live));
  EXPECT_FALSE(group.in_leaf(pid, CgroupLeaf::Images));
  ASSERT_TRUE(group.move(pid, CgroupLeaf::Images).has_value());
  EXPECT_TRUE(group.in_leaf(pid, CgroupLeaf::Images));
  EXPECT_FALSE(group.in_leaf(::getpid(), CgroupLeaf::Images));
}

// A move writes one hierarchy after the other; between the writes the process is in `live/` of one and in
// `images/` of another. settled_in says where it is in all of them (the real-time plan waits for that: the v1 cpu
// hierarchy holds the real-time budget).
TEST_F(CgroupLeaves, SettledIn_OnlyOnceEveryHierarchyHoldsIt) {
  const pid_t pid = child();
  // The child joins one hierarchy after the other too: once it answers a byte it has joined them all.
  ASSERT_TRUE(tell(pid, 'm', true));
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  EXPECT_TRUE(group.settled_in(pid, CgroupLeaf::Live));
  EXPECT_FALSE(group.settled_in(pid, CgroupLeaf::Images));
  EXPECT_FALSE(group.settled_in(::getpid(), CgroupLeaf::Live));
  const auto& v2 = group.unified_dir();
  if (!v2 || group.description().find("(v1 ") == std::string::npos) {
    GTEST_SKIP() << "the group is in one hierarchy here: no move can be half done";
  }
  // Half a move: the v2 hierarchy only, as the placer's first write leaves it.
  {
    std::ofstream procs(*v2 / "images" / "cgroup.procs");
    procs << pid;
  }
  ASSERT_TRUE(group.in_leaf(pid, CgroupLeaf::Images));
  EXPECT_FALSE(group.settled_in(pid, CgroupLeaf::Images));
  EXPECT_FALSE(group.settled_in(pid, CgroupLeaf::Live));
  ASSERT_TRUE(group.move(pid, CgroupLeaf::Images).has_value());
  EXPECT_TRUE(group.settled_in(pid, CgroupLeaf::Images));
}

TEST_F(CgroupLeaves, PrepareMove_RunLater_MovesBack) {
  const pid_t pid = child();
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  ASSERT_TRUE(group.move(pid, CgroupLeaf::Images).has_value());
  auto move = group.prepare_move(pid, CgroupLeaf::Live);
  ASSERT_TRUE(move.has_value()) << move.error().to_string();
  std::thread([&] { EXPECT_TRUE(move->run().has_value()); }).join();
  EXPECT_TRUE(contains(group.members(CgroupLeaf::Live), pid));
}

TEST_F(CgroupLeaves, Move_GoneProcess_Error) {
  const pid_t pid = child();
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  ASSERT_TRUE(tell(pid, 'x', false));
  ASSERT_EQ(::waitpid(pid, nullptr, 0), pid);
  children.clear();
  EXPECT_FALSE(group.move(pid, CgroupLeaf::Images).has_value());
}

TEST_F(CgroupLeaves, KillLive_LiveAndItsForks_ImagesSpared) {
  const pid_t live = child();
  const pid_t stray = child();
  const pid_t image = child();
  for (const pid_t pid : {live, stray, image}) ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, pid));
  ASSERT_TRUE(group.move(image, CgroupLeaf::Images).has_value());
  if (!group.kill_live()) GTEST_SKIP() << "no cgroup v2 hierarchy here (no cgroup.kill)";
  for (const pid_t pid : {live, stray}) {
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  }
  EXPECT_EQ(::kill(image, 0), 0) << "the image was killed with the live leaf";
}

// The attack of docs/sandbox.md (OOM_IMAGES) in small: the live touches memory, an image of it is taken
// and moved out, the live then touches more than its leaf may hold. The OOM killer kills the live — whose
// leaf is out of memory — not the image, although the image's pages are charged to that leaf (a page stays
// charged where it was first touched); and the kill is counted.
TEST_F(CgroupLeaves, LiveLeafOutOfMemory_KillsTheLive_NotTheImage_Counted) {
  if (!group.live_oom_kills()) GTEST_SKIP() << "no memory controller here";
  const std::uint64_t before = *group.live_oom_kills();
  const pid_t live = child(40);
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, live));
  const pid_t image = child(40);  // stands for the image: its 40 MiB charged to the live leaf, where it touched them
  ASSERT_TRUE(listed_in(group, CgroupLeaf::Live, image));
  ASSERT_TRUE(tell(image, 'm', true));
  ASSERT_TRUE(group.move(image, CgroupLeaf::Images).has_value());
  ASSERT_TRUE(tell(live, 'm', false));  // 40 more MiB in a leaf of 64: out of memory
  int status = 0;
  ASSERT_EQ(::waitpid(live, &status, 0), live);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  EXPECT_EQ(::kill(image, 0), 0) << "the OOM killer took the image";
  EXPECT_GT(group.live_oom_kills().value_or(0), before);
}

}  // namespace
}  // namespace rejuv::sys
