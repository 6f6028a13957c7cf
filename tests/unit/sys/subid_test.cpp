// Subordinate ids (rejuv/sys/subid.hpp): the subuid/subgid parser, the block lease and its refusals, and — by
// effect, with real processes — a service spawned by a spawner without root runs as a subordinate uid of its own,
// never the spawner's: its /proc/PID/status says so, and a file of mode 0600 of the spawner's uid is closed to it.
//
// The effect tests run the spawner as `nobody`, which needs a subordinate range for nobody in /etc/subuid and
// /etc/subgid: `./rejuv test` adds one (docs/sandbox.md); without it they fail and say how to add it.
#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>
#include <string>

#include "rejuv/sys/process.hpp"
#include "rejuv/sys/subid.hpp"

namespace rejuv::sys {
namespace {

namespace fs = std::filesystem;

// ---- the parser ----

TEST(SubidParser, WellFormedLines_EntriesInFileOrder) {
  const SubidFile f = parse_subid_file("alice:100000:65536\n1001:165536:65536\n");
  ASSERT_EQ(f.entries.size(), 2U);
  EXPECT_EQ(f.entries[0].owner, "alice");
  EXPECT_EQ(f.entries[0].range.first, 100000U);
  EXPECT_EQ(f.entries[0].range.count, 65536U);
  EXPECT_EQ(f.entries[1].owner, "1001");
  EXPECT_TRUE(f.skipped.empty());
}

TEST(SubidParser, CommentsAndEmptyLines_IgnoredUnlisted) {
  const SubidFile f = parse_subid_file("# ranges\n\nalice:100000:65536");  // no final newline either
  ASSERT_EQ(f.entries.size(), 1U);
  EXPECT_TRUE(f.skipped.empty());
}

TEST(SubidParser, BadLines_SkippedWithTheirNumberAndReason_GoodLinesKept) {
  const SubidFile f = parse_subid_file(
      "alice:100000\n"             // 1: two fields
      "alice:100000:65536:x\n"     // 2: four fields
      ":100000:65536\n"            // 3: no owner
      "alice:0x1000:65536\n"       // 4: not decimal
      "alice:100000:0\n"           // 5: empty range
      "alice:4294967295:2\n"       // 6: past 2^32
      "alice:-1:10\n"              // 7: negative
      "alice: 5:10\n"              // 8: a space
      "bob:200000:10\n");          // 9: good
  ASSERT_EQ(f.entries.size(), 1U);
  EXPECT_EQ(f.entries[0].owner, "bob");
  ASSERT_EQ(f.skipped.size(), 8U);
  for (std::size_t i = 0; i < f.skipped.size(); ++i) {
    EXPECT_EQ(f.skipped[i].line, i + 1) << f.skipped[i].reason;
    EXPECT_FALSE(f.skipped[i].reason.empty());
  }
}

TEST(SubidParser, RangeEndingExactlyAt2To32_Kept) {
  const SubidFile f = parse_subid_file("alice:4294967295:1\n");
  ASSERT_EQ(f.entries.size(), 1U);
  EXPECT_EQ(f.entries[0].range.end(), std::uint64_t{1} << 32U);
}

TEST(SubidRanges, OneUserSeveralRanges_AllInFileOrder) {
  const SubidFile f = parse_subid_file("alice:300000:10\nbob:1:5\nalice:100000:20\n");
  const auto r = ranges_of(f, "alice", 1000);
  ASSERT_EQ(r.size(), 2U);
  EXPECT_EQ(r[0].first, 300000U);
  EXPECT_EQ(r[1].first, 100000U);
}

TEST(SubidRanges, ByNameAndByUid_BothMatch_OthersNot) {
  const SubidFile f = parse_subid_file("alice:100:1\n1000:200:1\nalicex:300:1\n10000:400:1\nbob:500:1\n");
  const auto r = ranges_of(f, "alice", 1000);
  ASSERT_EQ(r.size(), 2U);
  EXPECT_EQ(r[0].first, 100U);
  EXPECT_EQ(r[1].first, 200U);
  EXPECT_TRUE(ranges_of(f, "carol", 1001).empty());
}

TEST(SubidRanges, NthId_CountsThroughTheRangesInOrder) {
  const std::array<IdRange, 2> r{IdRange{300, 2}, IdRange{100, 3}};
  EXPECT_EQ(nth_id(r, 0), 300U);
  EXPECT_EQ(nth_id(r, 1), 301U);
  EXPECT_EQ(nth_id(r, 2), 100U);
  EXPECT_EQ(nth_id(r, 4), 102U);
  EXPECT_FALSE(nth_id(r, 5).has_value());
}

TEST(SubidRanges, FreeRange_OverlapsNoEntryAndNoRootBlock) {
  const std::array<SubidFile, 1> files{parse_subid_file("alice:393216:65536\nbob:500000:10\n")};
  const IdRange r = free_range(files);
  EXPECT_EQ(r.count, 65536U);
  EXPECT_EQ(r.first % 65536U, 0U);
  for (const SubidEntry& e : files[0].entries) EXPECT_FALSE(r.overlaps(e.range)) << e.owner;
  EXPECT_FALSE(r.overlaps(IdRange{kServiceUidBase, kUidBlocks * kUidsPerBlock}));
  EXPECT_EQ(r.first, 8U * 65536U);  // 6·65536 on is alice's, 7·65536 on holds bob's 500000
}

// ---- the lease ----

// Temporary subuid/subgid files for this process's uid.
class SubidFiles {
 public:
  SubidFiles(const std::string& subuid, const std::string& subgid)
      : dir_(fs::temp_directory_path() / ("rejuv_subid_" + std::to_string(::getpid()) + "_" +
                                          std::to_string(counter_++))) {
    fs::create_directories(dir_);
    std::ofstream(dir_ / "subuid") << subuid;
    std::ofstream(dir_ / "subgid") << subgid;
    sources_.subuid = dir_ / "subuid";
    sources_.subgid = dir_ / "subgid";
  }
  ~SubidFiles() { fs::remove_all(dir_); }
  SubidFiles(const SubidFiles&) = delete;
  SubidFiles& operator=(const SubidFiles&) = delete;
  [[nodiscard]] const SubidSources& sources() const { return sources_; }

 private:
  static inline int counter_ = 0;
  fs::path dir_;
  SubidSources sources_;
};

std::string my_name() {
  const passwd* pw = ::getpwuid(::getuid());
  return pw != nullptr ? pw->pw_name : "";
}

TEST(SubordinateBlock, NoRangeForTheUser_RefusedSayingHowToAddOne) {
  const SubidFiles files("someoneelse:393216:65536\n", "someoneelse:393216:65536\n");
  auto block = SubordinateBlock::lease(::getuid(), 0, files.sources());
  ASSERT_FALSE(block.has_value());
  EXPECT_EQ(block.error().kind, SubidError::Kind::NoRange);
  const std::string& m = block.error().message;
  EXPECT_NE(m.find("usermod --add-subuids"), std::string::npos) << m;
  EXPECT_NE(m.find("--add-subgids"), std::string::npos) << m;
  EXPECT_NE(m.find(" " + my_name()), std::string::npos) << m;
  EXPECT_NE(m.find("--insecure-sandbox"), std::string::npos) << m;
  EXPECT_EQ(m.find("393216-"), std::string::npos) << "suggested a range someone else has: " << m;
}

TEST(SubordinateBlock, UidsButNoGids_Refused) {
  const SubidFiles files(my_name() + ":393216:65536\n", "");
  auto block = SubordinateBlock::lease(::getuid(), 0, files.sources());
  ASSERT_FALSE(block.has_value());
  EXPECT_EQ(block.error().kind, SubidError::Kind::NoRange);
  EXPECT_NE(block.error().message.find("no subordinate gids"), std::string::npos) << block.error().message;
}

TEST(SubordinateBlock, RangeSmallerThanABlock_Refused) {
  const SubidFiles files(my_name() + ":393216:255\n", my_name() + ":393216:65536\n");
  auto block = SubordinateBlock::lease(::getuid(), 0, files.sources());
  ASSERT_FALSE(block.has_value());
  EXPECT_EQ(block.error().kind, SubidError::Kind::NoRange);
}

TEST(SubordinateBlock, NoNewuidmap_RefusedSayingWhichPackage) {
  const SubidFiles files(my_name() + ":393216:65536\n", my_name() + ":393216:65536\n");
  SubidSources sources = files.sources();
  sources.newuidmap = "/nonexistent/newuidmap";
  auto block = SubordinateBlock::lease(::getuid(), 0, sources);
  ASSERT_FALSE(block.has_value());
  EXPECT_EQ(block.error().kind, SubidError::Kind::NoHelper);
  EXPECT_NE(block.error().message.find("apt-get install uidmap"), std::string::npos) << block.error().message;
}

TEST(SubordinateBlock, TwoLeasesOfOneUser_DisjointIdsFromTheRanges) {
  // By uid, two ranges: the ids count through both.
  const std::string uid = std::to_string(::getuid());
  const SubidFiles files(uid + ":393216:256\n" + uid + ":600000:256\n", uid + ":700000:512\n");
  auto a = SubordinateBlock::lease(::getuid(), 0, files.sources());
  auto b = SubordinateBlock::lease(::getuid(), 0, files.sources());
  ASSERT_TRUE(a.has_value()) << a.error().message;
  ASSERT_TRUE(b.has_value()) << b.error().message;
  EXPECT_NE(a->block(), b->block());
  const auto& first = a->block() == 0 ? *a : *b;
  const auto& second = a->block() == 0 ? *b : *a;
  EXPECT_EQ(first.ids_of(0).uid, 393216U);
  EXPECT_EQ(first.ids_of(255).uid, 393216U + 255U);
  EXPECT_EQ(second.ids_of(0).uid, 600000U);
  EXPECT_EQ(first.ids_of(3).gid, 700003U);
  EXPECT_EQ(second.ids_of(3).gid, 700000U + 256U + 3U);
  // A third finds none free.
  auto c = SubordinateBlock::lease(::getuid(), 0, files.sources());
  ASSERT_FALSE(c.has_value());
  EXPECT_EQ(c.error().kind, SubidError::Kind::Busy);
}

// ---- by effect: a spawner without root, its service as a subordinate uid ----

// What the spawner as nobody found, written back to the test through a pipe.
struct AsNobody {
  int exit_code = -1;
  std::string report;
};

// Runs `body` in a child process that has become nobody (uid, gid, no groups); `body` writes its report to the
// fd it is given and returns the child's exit code. Skips unless root and nobody exists.
AsNobody run_as_nobody(const std::function<int(int)>& body) {
  AsNobody out;
  const passwd* nobody = ::getpwnam("nobody");
  if (nobody == nullptr) return out;
  const uid_t uid = nobody->pw_uid;
  const gid_t gid = nobody->pw_gid;
  std::array<int, 2> p{-1, -1};
  if (::pipe2(p.data(), O_CLOEXEC) != 0) return out;
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(p[0]);
    if (::setgroups(0, nullptr) != 0 || ::setresgid(gid, gid, gid) != 0 || ::setresuid(uid, uid, uid) != 0) {
      ::_exit(90);
    }
    ::_exit(body(p[1]));
  }
  ::close(p[1]);
  std::array<char, 4096> buf{};
  for (ssize_t n = 0; (n = ::read(p[0], buf.data(), buf.size())) > 0;) out.report.append(buf.data(), n);
  ::close(p[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return out;
}

void say(int fd, const std::string& text) { (void)!::write(fd, text.data(), text.size()); }

// nobody's subordinate uids, from the system's /etc/subuid.
std::vector<IdRange> nobody_uids() {
  std::ifstream in("/etc/subuid");
  std::stringstream text;
  text << in.rdbuf();
  const passwd* nobody = ::getpwnam("nobody");
  return nobody == nullptr ? std::vector<IdRange>{} : ranges_of(parse_subid_file(text.str()), "nobody", nobody->pw_uid);
}

class SubordinateUids : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root to become nobody";
    if (::getpwnam("nobody") == nullptr) GTEST_SKIP() << "no user nobody";
    ASSERT_FALSE(nobody_uids().empty())
        << "nobody has no subordinate uids: `./rejuv test` adds them, or as root: usermod --add-subuids "
           "393216-458751 --add-subgids 393216-458751 nobody (docs/sandbox.md)";
  }
};

// The spawner's side as nobody: spawns `argv` in namespaces, with its subordinate ids (or, with `mapped` false,
// unmapped: the spawner's uid outside), fd 2 to the report pipe; reports the service's Uid line and its exit.
int spawn_and_report(int report, const std::vector<std::string>& argv, bool mapped, bool read_status) {
  auto block = SubordinateBlock::lease(::getuid(), static_cast<std::uint32_t>(::getpid()));
  if (!block) {
    say(report, "lease: " + block.error().message);
    return 10;
  }
  SpawnSpec spec;
  spec.executable = argv.front();
  spec.args.assign(argv.begin() + 1, argv.end());
  const UniqueFd null(::open("/dev/null", O_RDWR | O_CLOEXEC));
  spec.fds = {{0, null.get()}, {1, null.get()}, {2, report}};
  spec.isolation = Isolation::Namespaces;
  if (mapped) spec.mapped_ids = block->ids_of(7);
  auto child = spawn(spec);
  if (!child) {
    say(report, "spawn: " + child.error().to_string());
    return 11;
  }
  if (read_status) {
    std::ifstream status("/proc/" + std::to_string(child->pid()) + "/status");
    for (std::string line; std::getline(status, line);) {
      if (line.rfind("Uid:", 0) == 0 || line.rfind("Gid:", 0) == 0) say(report, line + "\n");
    }
    say(report, "expected " + std::to_string(block->ids_of(7).uid) + " " + std::to_string(block->ids_of(7).gid) + "\n");
    (void)child->signal(SIGKILL);
  }
  auto exit = child->wait();
  if (!exit) return 12;
  return exit->how == ExitStatus::How::Exited ? exit->value : 100 + exit->value;
}

std::vector<std::uint64_t> numbers_after(const std::string& report, const std::string& tag) {
  std::vector<std::uint64_t> out;
  const std::size_t at = report.find(tag);
  if (at == std::string::npos) return out;
  std::istringstream line(report.substr(at + tag.size(), report.find('\n', at) - at - tag.size()));
  for (std::uint64_t n = 0; line >> n;) out.push_back(n);
  return out;
}

TEST_F(SubordinateUids, SpawnedWithoutRoot_RunsAsASubordinateUidOfItsOwn_NotTheSpawners) {
  const AsNobody r = run_as_nobody([](int fd) { return spawn_and_report(fd, {"/bin/sleep", "60"}, true, true); });
  ASSERT_NE(r.exit_code, 90) << "could not become nobody";
  ASSERT_NE(r.exit_code, 10) << r.report;
  ASSERT_NE(r.exit_code, 11) << r.report;
  std::printf("the service as seen by the spawner (nobody):\n%s", r.report.c_str());
  const auto uids = numbers_after(r.report, "Uid:");
  const auto gids = numbers_after(r.report, "Gid:");
  const auto expected = numbers_after(r.report, "expected ");
  ASSERT_EQ(uids.size(), 4U) << r.report;
  ASSERT_EQ(gids.size(), 4U) << r.report;
  ASSERT_EQ(expected.size(), 2U) << r.report;
  const uid_t nobody = ::getpwnam("nobody")->pw_uid;
  bool in_range = false;
  for (const IdRange& range : nobody_uids()) in_range = in_range || (uids[0] >= range.first && uids[0] < range.end());
  EXPECT_TRUE(in_range) << "uid " << uids[0] << " is not one of nobody's subordinate uids";
  for (const std::uint64_t u : uids) {
    EXPECT_NE(u, nobody) << "the service runs as the spawner's uid";
    EXPECT_EQ(u, expected[0]) << r.report;  // real, effective, saved, filesystem
  }
  for (const std::uint64_t g : gids) EXPECT_EQ(g, expected[1]) << r.report;
}

// A file of mode 0600 of the spawner's uid (the launch file's signing key): the service cannot read it. With
// the same spawn unmapped (the service is the spawner's uid outside) it can: the check can fail.
TEST_F(SubordinateUids, FileOfTheSpawnersUid_Mode0600_ClosedToTheService) {
  const std::string path = "/tmp/rejuv_subid_key_" + std::to_string(::getpid());
  {
    std::ofstream(path) << "secret signing key\n";
  }
  const passwd* nobody = ::getpwnam("nobody");
  ASSERT_EQ(::chown(path.c_str(), nobody->pw_uid, nobody->pw_gid), 0);
  ASSERT_EQ(::chmod(path.c_str(), 0600), 0);
  const AsNobody mapped = run_as_nobody([&](int fd) { return spawn_and_report(fd, {"/bin/cat", path}, true, false); });
  const AsNobody unmapped =
      run_as_nobody([&](int fd) { return spawn_and_report(fd, {"/bin/cat", path}, false, false); });
  fs::remove(path);
  EXPECT_EQ(unmapped.exit_code, 0) << "as the spawner's uid the service should read it: " << unmapped.report;
  std::printf("cat as the service: %s", mapped.report.c_str());
  EXPECT_EQ(mapped.exit_code, 1) << mapped.report;
  EXPECT_NE(mapped.report.find("Permission denied"), std::string::npos) << mapped.report;
}

// newuidmap refuses a map outside the user's ranges: the spawn fails with what it said, and leaves no child.
TEST_F(SubordinateUids, MapOutsideTheRange_SpawnFailsWithTheHelpersWords) {
  const AsNobody r = run_as_nobody([](int fd) {
    SpawnSpec spec;
    spec.executable = "/bin/true";
    spec.isolation = Isolation::Namespaces;
    spec.mapped_ids = MappedIds{.uid = 4000000000U, .gid = 4000000000U};
    auto child = spawn(spec);
    if (child) return 20;
    say(fd, child.error().to_string());
    auto left = count_children(::getpid());
    return left && *left == 0 ? 0 : 21;
  });
  EXPECT_EQ(r.exit_code, 0) << r.report;
  std::printf("%s\n", r.report.c_str());
  EXPECT_NE(r.report.find("newuidmap"), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("4000000000"), std::string::npos) << r.report;
}

}  // namespace
}  // namespace rejuv::sys
