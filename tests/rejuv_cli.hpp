// Running the `rejuv` program as a user does, from a test: the real binary, no shell (no quoting issues), its
// stdout and stderr captured to files in a scratch folder of the test's own. Shared by the CLI tests
// (tests/unit/policy/cli_test.cpp) and the multi-process tests that drive `rejuv run` / `rejuv soak`.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <system_error>
#include <vector>

extern char** environ;  // NOLINT: the child gets the test's environment (CYCLONEDDS_URI, …)

namespace rejuv::test_support {

inline const std::filesystem::path kRepo(REJUV_SOURCE_DIR);
inline const std::filesystem::path kRejuv = std::filesystem::path(REJUV_BINARY_DIR) / "tools" / "rejuv" / "rejuv";

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A shipped graph that extends the paper's square (launch/quad_square: `include: "quad_square_paper.launch.pbtxt"`
// and its own fields) written to `to`, including `base` (an edited copy of the paper's square) instead.
inline void write_extending(const std::string& shipped, const std::filesystem::path& base,
                            const std::filesystem::path& to) {
  std::string text = slurp(kRepo / "launch" / shipped);
  const std::string paper = "include: \"quad_square_paper.launch.pbtxt\"";
  const auto at = text.find(paper);
  ASSERT_NE(at, std::string::npos) << shipped << " does not include the paper's square";
  text.replace(at, paper.size(), "include: \"" + base.string() + "\"");
  std::ofstream(to) << text;
}

// How many times `needle` occurs in `text` (e.g. rows of a CSV that end a certain way).
inline std::size_t count_of(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

struct CliOutcome {
  int exit_code = -1;  // -1: ended by a signal (a crash)
  std::string out, err;
};

// Starts `program <args>` (no shell; the program by path) with stdout and stderr going to `dir`/stdout and
// `dir`/stderr. The child's pid, or -1.
inline pid_t start_program(const std::filesystem::path& dir, const std::filesystem::path& program_path,
                           std::vector<std::string> args) {
  const std::string out = (dir / "stdout").string();
  const std::string err = (dir / "stderr").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  std::vector<char*> argv;
  std::string program = program_path.string();
  argv.push_back(program.data());
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

// Waits for a child of start_program and collects what it wrote to `dir`.
inline CliOutcome wait_program(const std::filesystem::path& dir, pid_t pid) {
  CliOutcome r;
  if (pid > 0) {
    int status = 0;
    if (::waitpid(pid, &status, 0) == pid && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  }
  r.out = slurp(dir / "stdout");
  r.err = slurp(dir / "stderr");
  return r;
}

// Runs `program <args>` to its end (start_program, wait_program).
inline CliOutcome run_program(const std::filesystem::path& dir, const std::filesystem::path& program_path,
                              std::vector<std::string> args) {
  return wait_program(dir, start_program(dir, program_path, std::move(args)));
}

// Runs `rejuv <args>` (run_program).
inline CliOutcome run_rejuv(const std::filesystem::path& dir, std::vector<std::string> args) {
  return run_program(dir, kRejuv, std::move(args));
}

// The UDP port of the network gate of a `rejuv run` started by start_program in `dir` (its log line
// "network gate: udp 127.0.0.1:PORT"), or 0 if the run ended first or `limit` passed.
inline std::uint16_t bound_gate_port(const std::filesystem::path& dir, pid_t run, std::chrono::seconds limit) {
  constexpr std::string_view kLine = "network gate: udp 127.0.0.1:";
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    const std::string err = slurp(dir / "stderr");
    if (const auto at = err.find(kLine); at != std::string::npos) {
      const auto end = err.find_first_not_of("0123456789", at + kLine.size());
      if (end != std::string::npos) return static_cast<std::uint16_t>(std::stoul(err.substr(at + kLine.size())));
    }
    siginfo_t ended{};
    if (::waitid(P_PID, static_cast<id_t>(run), &ended, WEXITED | WNOHANG | WNOWAIT) == 0 && ended.si_pid == run) {
      return 0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds{10});
  }
  return 0;
}

// A fixture with a scratch folder per test (`<prefix><pid>_<test name>` in the temp directory), removed after
// the test — or kept when it failed and keep_on_failure() says so.
class ScratchDirTest : public ::testing::Test {
 protected:
  explicit ScratchDirTest(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           (prefix_ + std::to_string(::getpid()) + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!(keep_on_failure() && HasFailure())) std::filesystem::remove_all(dir_, ec);
  }
  [[nodiscard]] virtual bool keep_on_failure() const { return false; }

  std::filesystem::path dir_;

 private:
  std::string prefix_;
};

}  // namespace rejuv::test_support
