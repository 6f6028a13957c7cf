// `rejuv soak` (issue 19, DESIGN §11): the real binary flies the shipped square with SR and attacks and samples
// the kernel's, the plant's and every service's memory, fds, mappings and processes. The short form (30 cycles)
// runs in the default suite: it checks that the soak reaches its cycles, writes every series readable and
// judges them flat. The 1000-cycle soak is DISABLED_ here and run only as the ctest label `soak`
// (`./rejuv test -L soak`; tests/multiproc/CMakeLists.txt). No timing is asserted.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../test_domain.hpp"

namespace {

const std::filesystem::path kRepo(REJUV_SOURCE_DIR);
const std::filesystem::path kRejuv = std::filesystem::path(REJUV_BINARY_DIR) / "tools" / "rejuv" / "rejuv";

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Outcome {
  int exit_code = -1;  // -1: ended by a signal
  std::string out, err, csv;
};

class Soak : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("rejuv_soak_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) std::filesystem::remove_all(dir_, ec);  // kept on failure: soak.csv tells what grew
  }

  // `rejuv soak launch/quad_square.launch.pbtxt <extra>` on this process's own DDS domain. The soak's kernel
  // kills and reaps every process it started before it exits (Kernel::shutdown).
  Outcome soak(const std::vector<std::string>& extra) const {
    const std::string out = (dir_ / "stdout").string();
    const std::string err = (dir_ / "stderr").string();
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    std::vector<std::string> all{kRejuv.string(), "soak", (kRepo / "launch" / "quad_square.launch.pbtxt").string(),
                                 "--domain", std::to_string(rejuv::test_support::kOwnDdsDomain), "--out",
                                 dir_.string()};
    all.insert(all.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (std::string& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    Outcome r;
    if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) == 0) {
      int status = 0;
      if (::waitpid(pid, &status, 0) == pid && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
    }
    posix_spawn_file_actions_destroy(&actions);
    r.out = slurp(out);
    r.err = slurp(err);
    r.csv = slurp(dir_ / "soak.csv");
    return r;
  }

  std::filesystem::path dir_;
};

std::size_t lines(const std::string& text) {
  std::size_t n = 0;
  for (const char c : text) n += c == '\n' ? 1 : 0;
  return n;
}

TEST_F(Soak, ThirtyCycles_ReachesThemAndEverySeriesIsFlat) {
  const Outcome r = soak({"--cycles", "30", "--sample-every", "2"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("rejuv soak: flat over 30 cycles"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("unreadable"), std::string::npos) << r.out;  // every /proc file this soak reads
  // Header and one row per sample: cycles 0, 2, …, 30.
  EXPECT_EQ(lines(r.csv), 1U + 16U) << r.csv;
  for (const char* column : {"kernel_rss_kb", "plant_rss_kb", "ekf2_rss_kb", "kernel_fds", "ekf2_fds",
                             "kernel_maps", "processes", "lqr_control_procs"}) {
    EXPECT_NE(r.csv.find(column), std::string::npos) << column;
  }
}

// Issue 19's done criterion: ≥ 1000 SR cycles with flat memory, fds and processes. About 3 min of wall time
// on two cores; run it with `./rejuv test -L soak`.
TEST_F(Soak, DISABLED_ThousandCycles_MemoryFdsAndProcessesStayFlat) {
  const Outcome r = soak({"--cycles", "1000", "--sample-every", "10"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("rejuv soak: flat over 1000 cycles"), std::string::npos) << r.out;
  std::printf("%s", r.out.c_str());
}

}  // namespace
