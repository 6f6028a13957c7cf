// What the security tests that fly a whole mission share (compromised_mission_test.cpp,
// rollback_attack_test.cpp): the graph's text, whether its services are built, the processes of a
// service's session, the run's log in a temporary file, and a guard that leaves no process of a session behind.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "../proc_stat.hpp"
#include "graph_fixture.hpp"

namespace rejuv::testing::mission {

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The first executable of the graph (a service or its plant) that is not built, if any: the test fails on it.
inline std::optional<std::filesystem::path> missing_executable(const launch::LoadedLaunch& g) {
  for (const proto::ServiceSpec& s : g.graph.services()) {
    if (!std::filesystem::exists(kServiceDir / s.executable())) return kServiceDir / s.executable();
  }
  const std::filesystem::path plant = kServiceDir / g.graph.plant().executable();
  if (!std::filesystem::exists(plant)) return plant;
  return std::nullopt;
}

// launch/quad_square in `dir` with the paper's file it includes changed for a test: the alignment 8 s instead of
// 20, the clock REALTIME when asked, and `attacks` (more `attacks { … }` entries) after its control attack; the
// relative paths (the policy) as seen from launch/. Empty when the paper's file no longer reads as expected.
inline std::filesystem::path square_in(const std::filesystem::path& dir, bool realtime, std::string_view attacks = {}) {
  namespace fs = std::filesystem;
  const fs::path launch = fs::path(REJUV_SOURCE_DIR) / "launch";
  std::string paper = read_text(launch / "quad_square_paper.launch.pbtxt");
  const std::string control_attack = "attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }";
  const std::size_t at = paper.find(control_attack);
  const std::size_t clock = paper.find("clock: LOCKSTEP");
  const std::size_t align = paper.find("alignment_s: 20");
  if (at == std::string::npos || clock == std::string::npos || align == std::string::npos) return {};
  paper.replace(align, std::string_view("alignment_s: 20").size(), "alignment_s: 8");
  if (!attacks.empty()) paper.insert(at + control_attack.size(), "\n  " + std::string(attacks));
  if (realtime) paper.replace(paper.find("clock: LOCKSTEP"), std::string_view("clock: LOCKSTEP").size(), "clock: REALTIME");
  for (std::size_t up = paper.find("\"../"); up != std::string::npos; up = paper.find("\"../", up)) {
    paper.replace(up + 1, 3, (launch.parent_path() / "").string());
  }
  fs::create_directories(dir);
  std::ofstream(dir / "quad_square_paper.launch.pbtxt") << paper;
  std::ofstream(dir / "quad_square.launch.pbtxt") << read_text(launch / "quad_square.launch.pbtxt");
  return dir / "quad_square.launch.pbtxt";
}

// launch/quad_square as square_in makes it, in a directory of this process that is gone afterwards, parsed, and
// its executables checked built: `out` holds it, or the test has failed.
inline void load_square(bool realtime, std::string_view attacks, std::optional<launch::LoadedLaunch>& out) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rejuv_square_" + std::to_string(::getpid()));
  const std::filesystem::path file = square_in(dir, realtime, attacks);
  ASSERT_FALSE(file.empty()) << "launch/quad_square_paper.launch.pbtxt no longer has its control attack, clock or alignment";
  auto graph = launch::parse_launch(read_text(file), file);
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(graph.has_value()) << graph.error().to_string();
  if (const auto missing = missing_executable(*graph)) FAIL() << "not built: " << missing->string();
  out = std::move(*graph);
}

// /proc/<pid>/stat (tests/proc_stat.hpp), shared with the other multi-process tests.
using test_support::proc_stat;
using test_support::ProcStat;

// Whether `pid` is this process or descends from it. A session id is a pid: once the session the test watched
// has no process left, the number can come back as another test's service (each is a session leader), which
// must not be counted or killed here. Every process a service makes descends from the kernel, this process
// (a subreaper: an orphan comes back to it).
inline bool descends_from_us(pid_t pid) {
  for (int depth = 0; pid > 1 && depth < 64; ++depth) {
    if (pid == ::getpid()) return true;
    pid = proc_stat(pid).parent;
  }
  return false;
}

// Every living process of session `sid` that descends from this process (from /proc; a zombie is dead
// already: its parent reaps it).
inline std::vector<pid_t> session_members(pid_t sid) {
  std::vector<pid_t> out;
  std::error_code ec;
  for (const std::filesystem::directory_entry& e : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    pid_t pid = 0;
    const auto [end, err] = std::from_chars(name.data(), name.data() + name.size(), pid);
    if (err != std::errc{} || end != name.data() + name.size()) continue;
    if (::getsid(pid) != sid) continue;
    if (proc_stat(pid).state == 'Z' || !descends_from_us(pid)) continue;
    out.push_back(pid);
  }
  return out;
}

// The kernel's options for a mission: the plant as time master, an idle deadline a loaded machine keeps, the
// ground link on any free port (tests run side by side), the log into `log`.
inline kernel::KernelOptions mission_options(std::FILE* log) {
  kernel::KernelOptions options = test_options();
  options.time_master = kernel::TimeMaster::Plant;
  options.idle_deadline = std::chrono::seconds{10};
  options.network_port = 0;
  options.log = log;
  return options;
}

// The kernel and service log of the run, in a temporary file the test reads back.
class RunLog {
 public:
  RunLog() : file_(std::tmpfile()) {}
  [[nodiscard]] std::FILE* get() const { return file_.get(); }
  [[nodiscard]] std::string text() const {
    if (!file_) return {};
    std::fflush(file_.get());
    return read_text("/proc/self/fd/" + std::to_string(::fileno(file_.get())));
  }
  // The lines that contain `what`.
  [[nodiscard]] std::string lines_with(std::string_view what) const {
    std::istringstream in(text());
    std::string out;
    for (std::string line; std::getline(in, line);) {
      if (line.find(what) != std::string::npos) out += line + "\n";
    }
    return out;
  }
  // The lines that begin with `start` (a line a service wrote begins with its name: "[ext_link] …").
  [[nodiscard]] std::vector<std::string> lines_starting(std::string_view start) const {
    std::istringstream in(text());
    std::vector<std::string> out;
    for (std::string line; std::getline(in, line);) {
      if (line.starts_with(start)) out.push_back(line);
    }
    return out;
  }

 private:
  struct Close {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, Close> file_;
};

// Kills and reaps whatever of a session is left when the test ends, also on failure (the kernel, this
// process, is the parent of every process a service can make). Declared before the kernel: runs after it.
class SessionGuard {
 public:
  SessionGuard() = default;
  SessionGuard(const SessionGuard&) = delete;
  SessionGuard& operator=(const SessionGuard&) = delete;
  ~SessionGuard() {
    if (!sid_) return;
    for (const pid_t pid : session_members(*sid_)) {
      (void)::kill(pid, SIGKILL);
      (void)::waitpid(pid, nullptr, 0);
    }
  }
  void watch(pid_t sid) { sid_ = sid; }

 private:
  std::optional<pid_t> sid_{};
};

}  // namespace rejuv::testing::mission
