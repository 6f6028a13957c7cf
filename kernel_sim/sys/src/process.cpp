#include "rejuv/sys/process.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <grp.h>
#include <linux/close_range.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

namespace rejuv::sys {

namespace {
// glibc 2.36's <sys/pidfd.h> lacks C linkage for C++: call the system calls directly.
int pidfd_open(pid_t pid, unsigned flags) { return static_cast<int>(::syscall(SYS_pidfd_open, pid, flags)); }
int pidfd_send_signal(int pidfd, int sig) {
  return static_cast<int>(::syscall(SYS_pidfd_send_signal, pidfd, sig, nullptr, 0U));
}
}  // namespace

std::string ExitStatus::to_string() const {
  switch (how) {
    case How::Exited: return "exited with " + std::to_string(value);
    case How::Signaled: {
      const char* name = sigabbrev_np(value);
      return std::string("killed by SIG") + (name != nullptr ? name : std::to_string(value).c_str());
    }
  }
  return "?";
}

SysResult<ChildProcess> ChildProcess::adopt(pid_t pid) {
  const int fd = pidfd_open(pid, 0);
  if (fd < 0) {
    return last_error("pidfd_open");
  }
  return ChildProcess(pid, UniqueFd(fd));
}

SysResult<ChildProcess> ChildProcess::adopt_child(pid_t pid) {
  auto child = adopt(pid);
  if (!child) return child;
  // WNOWAIT: only asks; ECHILD when the pidfd's process is not our child.
  siginfo_t info{};
  if (::waitid(P_PIDFD, static_cast<id_t>(child->pidfd()), &info, WEXITED | WNOHANG | WNOWAIT) != 0) {
    const auto e = last_error("waitid(not a child)");
    child->pid_ = -1;  // not ours: never signalled or waited for
    return e;
  }
  return child;
}

ChildProcess::ChildProcess(ChildProcess&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)), pidfd_(std::move(other.pidfd_)), status_(std::move(other.status_)) {}

ChildProcess& ChildProcess::operator=(ChildProcess&& other) noexcept {
  if (this != &other) {
    kill_and_reap();
    pid_ = std::exchange(other.pid_, -1);
    pidfd_ = std::move(other.pidfd_);
    status_ = std::move(other.status_);
  }
  return *this;
}

namespace {
ExitStatus from_siginfo(const siginfo_t& info) {
  if (info.si_code == CLD_EXITED) {
    return ExitStatus{ExitStatus::How::Exited, info.si_status};
  }
  return ExitStatus{ExitStatus::How::Signaled, info.si_status};
}
}  // namespace

SysResult<std::optional<ExitStatus>> ChildProcess::try_wait() {
  if (status_ || pid_ <= 0) {
    return status_;
  }
  siginfo_t info{};
  int rc = -1;
  do {
    rc = ::waitid(P_PIDFD, static_cast<id_t>(pidfd_.get()), &info, WEXITED | WNOHANG);
  } while (rc < 0 && errno == EINTR);
  if (rc < 0) {
    return last_error("waitid");
  }
  if (info.si_pid == 0) {
    return std::optional<ExitStatus>{};
  }
  status_ = from_siginfo(info);
  return status_;
}

SysResult<ExitStatus> ChildProcess::wait() {
  if (status_) {
    return *status_;
  }
  if (pid_ <= 0) {
    return std::unexpected(SysError{"waitid", ECHILD});
  }
  siginfo_t info{};
  int rc = -1;
  do {
    rc = ::waitid(P_PIDFD, static_cast<id_t>(pidfd_.get()), &info, WEXITED);
  } while (rc < 0 && errno == EINTR);
  if (rc < 0) {
    return last_error("waitid");
  }
  status_ = from_siginfo(info);
  return *status_;
}

SysResult<void> ChildProcess::signal(int sig) const {
  if (pidfd_send_signal(pidfd_.get(), sig) != 0) {
    return last_error("pidfd_send_signal");
  }
  return {};
}

void ChildProcess::kill_and_reap() noexcept {
  if (pid_ <= 0 || status_) {
    return;
  }
  // A pidfd names exactly this process: no risk of signalling a recycled pid.
  pidfd_send_signal(pidfd_.get(), SIGKILL);
  (void)wait();
}

namespace {

// Everything the child needs, prepared before fork: after fork only async-signal-safe calls are allowed.
struct Prepared {
  std::vector<std::string> strings;
  std::vector<char*> argv;
  std::vector<char*> envp;
  std::vector<sock_filter> seccomp_scratch;
};

[[noreturn]] void child_fail(int pipe_fd, int stage, int err) {
  const std::array<int, 2> report{stage, err};
  (void)!::write(pipe_fd, report.data(), sizeof(report));
  ::_exit(127);
}

}  // namespace

SysResult<ChildProcess> spawn(const SpawnSpec& spec) {
  Prepared prep;
  prep.argv.push_back(const_cast<char*>(spec.executable.c_str()));  // NOLINT: execve's signature
  for (const std::string& a : spec.args) prep.argv.push_back(const_cast<char*>(a.c_str()));  // NOLINT
  prep.argv.push_back(nullptr);
  for (const std::string& e : spec.env) prep.envp.push_back(const_cast<char*>(e.c_str()));  // NOLINT
  prep.envp.push_back(nullptr);
  if (spec.seccomp != nullptr) {
    prep.seccomp_scratch.resize(spec.seccomp->scratch_size());
  }
  int max_target = 2;
  for (const auto& [target, source] : spec.fds) {
    if (target < 0 || source < 0 || target > 1000) {
      return std::unexpected(SysError{"spawn: fd layout", EBADF});
    }
    max_target = std::max(max_target, target);
  }

  std::array<int, 2> report_pipe{-1, -1};
  if (::pipe2(report_pipe.data(), O_CLOEXEC) != 0) {
    return last_error("pipe2");
  }
  UniqueFd report_read(report_pipe[0]);
  UniqueFd report_write(report_pipe[1]);
  const pid_t parent = ::getpid();

  const pid_t pid = ::fork();
  if (pid < 0) {
    return last_error("fork");
  }
  if (pid == 0) {
    // ---- child: async-signal-safe calls only ----
    // The report pipe moves above the fd layout first, so that placing the fds cannot clobber it.
    int wfd = ::fcntl(report_write.get(), F_DUPFD_CLOEXEC, max_target + 1);
    if (wfd < 0) wfd = report_write.get();
    if (::prctl(PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0) != 0) child_fail(wfd, 1, errno);
    if (::getppid() != parent) ::_exit(127);  // the kernel died before the prctl took effect
    if (spec.own_process_group && ::setpgid(0, 0) != 0) child_fail(wfd, 2, errno);
    // Move the sources out of the way first (they may collide with targets), then place them.
    std::array<int, 16> staged{};
    if (spec.fds.size() > staged.size()) child_fail(wfd, 3, EMFILE);
    for (std::size_t i = 0; i < spec.fds.size(); ++i) {
      staged[i] = ::fcntl(spec.fds[i].second, F_DUPFD_CLOEXEC, max_target + 1 + 16);
      if (staged[i] < 0) child_fail(wfd, 3, errno);
    }
    for (std::size_t i = 0; i < spec.fds.size(); ++i) {
      if (::dup2(staged[i], spec.fds[i].first) < 0) child_fail(wfd, 4, errno);  // dup2 clears CLOEXEC
    }
    // Every other fd (above stderr) closes at exec, the report pipe included.
    for (int fd = 3; fd <= max_target; ++fd) {
      bool wanted = false;
      for (const auto& [target, source] : spec.fds) wanted = wanted || target == fd;
      if (!wanted) ::close(fd);
    }
    if (::syscall(SYS_close_range, max_target + 1, ~0U, CLOSE_RANGE_CLOEXEC) != 0) child_fail(wfd, 5, errno);
    if (spec.uid) {
      const gid_t gid = *spec.uid;
      if (::setgroups(0, nullptr) != 0 || ::setresgid(gid, gid, gid) != 0 ||
          ::setresuid(*spec.uid, *spec.uid, *spec.uid) != 0) {
        child_fail(wfd, 6, errno);
      }
    }
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    if (spec.seccomp != nullptr) {
      if (const int err = spec.seccomp->install_in_child(prep.seccomp_scratch.data(), ::getpid()); err != 0) {
        child_fail(wfd, 7, err);
      }
    }
    ::execve(spec.executable.c_str(), prep.argv.data(), prep.envp.data());
    child_fail(wfd, 8, errno);
  }
  // ---- parent ----
  report_write.reset();
  auto child = ChildProcess::adopt(pid);
  std::array<int, 2> report{0, 0};
  ssize_t n = -1;
  do {
    n = ::read(report_read.get(), report.data(), sizeof(report));
  } while (n < 0 && errno == EINTR);
  if (!child) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    return std::unexpected(child.error());
  }
  if (n == static_cast<ssize_t>(sizeof(report))) {
    static constexpr std::array<std::string_view, 9> kStage{
        "spawn", "prctl(PR_SET_PDEATHSIG)", "setpgid", "fcntl(F_DUPFD)", "dup2", "close_range",
        "setuid", "seccomp", "execve"};
    const auto stage = static_cast<std::size_t>(report[0]);
    (void)child->wait();
    return std::unexpected(SysError{stage < kStage.size() ? kStage[stage] : "spawn", report[1]});
  }
  return std::move(*child);
}

SysResult<void> become_subreaper() {
  if (::prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0) {
    return last_error("prctl(PR_SET_CHILD_SUBREAPER)");
  }
  return {};
}

SysResult<pid_t> fork_sibling() {
  // The raw system call: glibc's fork() has no CLONE_PARENT. With no new stack the child continues on a
  // copy of this one, like fork(); glibc (≥ 2.34) reads the thread id from the kernel where it matters.
  const long pid = ::syscall(SYS_clone, CLONE_PARENT | SIGCHLD, nullptr, nullptr, nullptr, nullptr);
  if (pid < 0) return last_error("clone(CLONE_PARENT)");
  return static_cast<pid_t>(pid);
}

SysResult<void> make_non_dumpable() {
  if (::prctl(PR_SET_DUMPABLE, 0, 0, 0, 0) != 0) return last_error("prctl(PR_SET_DUMPABLE)");
  return {};
}

SysResult<int> pin_to_one_cpu(std::optional<int> cpu) {
  const int chosen = cpu.value_or(::sched_getcpu());
  if (chosen < 0 && !cpu) return last_error("sched_getcpu");
  if (chosen < 0 || chosen >= CPU_SETSIZE) return std::unexpected(SysError{"sched_setaffinity", EINVAL});
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(chosen, &set);
  if (::sched_setaffinity(0, sizeof(set), &set) != 0) return last_error("sched_setaffinity");
  return chosen;
}

SysResult<void> lower_priority(pid_t pid) {
  if (::setpriority(PRIO_PROCESS, static_cast<id_t>(pid), 19) != 0) return last_error("setpriority");
  return {};
}

SysResult<void> idle_priority(pid_t pid) {
  const sched_param param{};
  if (::sched_setscheduler(pid, SCHED_IDLE, &param) != 0) return last_error("sched_setscheduler(SCHED_IDLE)");
  return {};
}

SysResult<int> count_children(pid_t parent) {
  DIR* dir = ::opendir("/proc");
  if (dir == nullptr) {
    return last_error("opendir(/proc)");
  }
  int count = 0;
  while (const dirent* entry = ::readdir(dir)) {
    if (entry->d_name[0] < '0' || entry->d_name[0] > '9') continue;
    std::ifstream stat(std::string("/proc/") + entry->d_name + "/stat");
    std::string line;
    if (!std::getline(stat, line)) continue;
    // pid (comm) state ppid ...: comm may contain spaces and parentheses, so parse from the last ')'.
    const std::size_t close = line.rfind(')');
    if (close == std::string::npos || close + 4 >= line.size()) continue;
    const char state = line[close + 2];
    const pid_t ppid = static_cast<pid_t>(std::strtol(line.c_str() + close + 4, nullptr, 10));
    if (ppid == parent && state != 'X') ++count;
  }
  ::closedir(dir);
  return count;
}

}  // namespace rejuv::sys
