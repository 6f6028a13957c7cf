#include "rejuv/sys/process.hpp"

#include "rejuv/sys/file.hpp"

#include "raw_send.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <grp.h>
#include <linux/capability.h>
#include <linux/close_range.h>
#include <poll.h>
#include <sys/mount.h>
#include <sys/socket.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
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

SysResult<bool> ChildProcess::stopped_since_last_look() {
  if (status_ || pid_ <= 0) return false;
  siginfo_t info{};
  int rc = -1;
  do {
    rc = ::waitid(P_PIDFD, static_cast<id_t>(pidfd_.get()), &info, WSTOPPED | WNOHANG);
  } while (rc < 0 && errno == EINTR);
  if (rc < 0) return last_error("waitid");
  return info.si_pid != 0 && info.si_code == CLD_STOPPED;
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
  int max_target = 2;  // the highest fd of the child's layout (stderr at least)
  int executable = -1; // the binary, opened O_PATH by the spawner (spawn_supervised owns it)
};

// The stages a child reports a failure at (its index into kStage) and the listener hand-over.
enum ChildStage : int {
  kStageSpawn, kStagePdeathsig, kStageSession, kStageDupfd, kStageDup2, kStageCloseRange, kStageSetuid,
  kStageSeccomp, kStageExec, kStageUserns, kStageUnshare, kStageMount, kStageRlimit, kStageListener, kStageCgroup,
  kStageIdMap, kStageLandlock, kStageSetns,
};
constexpr std::array<std::string_view, 18> kStage{
    "spawn", "prctl(PR_SET_PDEATHSIG)", "setsid/setpgid", "fcntl(F_DUPFD)", "dup2", "close_range", "setuid",
    "seccomp", "execve", "unshare(CLONE_NEWUSER)", "unshare(CLONE_NEWNET|CLONE_NEWNS|CLONE_NEWIPC)",
    "read-only mounts (mount_setattr)", "setrlimit", "seccomp listener", "joining its cgroup (cgroup.procs)",
    "waiting for its uid/gid maps", "Landlock (landlock_restrict_self)", "setns(CLONE_NEWNET) into its network namespace"};

void child_report(int socket_fd, int stage, int err, int fd_to_pass) {
  const std::array<int, 2> report{stage, err};
  detail::send_raw_with_fd(socket_fd, report.data(), sizeof(report), fd_to_pass);
}

[[noreturn]] void child_fail(int socket_fd, int stage, int err) {
  child_report(socket_fd, stage, err, -1);
  ::_exit(127);
}

// struct mount_attr of <linux/mount.h> (Linux 5.12), which Debian 12's C library headers do not declare.
struct MountAttr {
  std::uint64_t attr_set;
  std::uint64_t attr_clr;
  std::uint64_t propagation;
  std::uint64_t userns_fd;
};
constexpr std::uint64_t kMountAttrRdonly = 0x1;
constexpr std::uint64_t kMountAttrNosuid = 0x2;
constexpr std::uint64_t kMountAttrNodev = 0x4;
#ifndef AT_RECURSIVE
constexpr int AT_RECURSIVE = 0x8000;  // NOLINT(readability-identifier-naming): <linux/fcntl.h>'s name
#endif
#ifndef SYS_mount_setattr
constexpr long SYS_mount_setattr = 442;  // NOLINT(readability-identifier-naming): the kernel's name
#endif

// Tells the spawner that its user namespace is made and waits (blocked in read) until the spawner has written
// its uid and gid maps (await_exec): a zero back means they are written. Anything else — the spawner failed and
// kills it — ends it.
void await_id_maps_in_child(int wfd) {
  child_report(wfd, kStageIdMap, 0, -1);
  int answer = -1;
  ssize_t n = -1;
  do {
    n = ::read(wfd, &answer, sizeof(answer));
  } while (n < 0 && errno == EINTR);
  if (n != static_cast<ssize_t>(sizeof(answer)) || answer != 0) child_fail(wfd, kStageIdMap, n < 0 ? errno : EIO);
}

// The child's isolation (async-signal-safe: raw system calls only). Without root: a user namespace of its own,
// mapped to its subordinate ids when it has them (otherwise unmapped: it stays the spawner's uid outside).
void isolate_in_child(int wfd, const SpawnSpec& spec) {
  if (::geteuid() != 0) {
    if (::unshare(CLONE_NEWUSER) != 0) child_fail(wfd, kStageUserns, errno);
    if (spec.mapped_ids) await_id_maps_in_child(wfd);
  }
  // A service given a network namespace (SpawnSpec::netns_fd) joined it first, one told to keep the spawner's
  // (keep_network) stays in it; the others get an empty one.
  const int net = spec.netns_fd >= 0 || spec.keep_network ? 0 : CLONE_NEWNET;
  if (::unshare(net | CLONE_NEWNS | CLONE_NEWIPC) != 0) child_fail(wfd, kStageUnshare, errno);
  // Nothing it mounts or remounts propagates back, and every mount it sees is read-only.
  if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) child_fail(wfd, kStageMount, errno);
  MountAttr attr{.attr_set = kMountAttrRdonly | kMountAttrNosuid | kMountAttrNodev, .attr_clr = 0,
                 .propagation = 0, .userns_fd = 0};
  if (::syscall(SYS_mount_setattr, AT_FDCWD, "/", AT_RECURSIVE, &attr, sizeof(attr)) != 0) {
    child_fail(wfd, kStageMount, errno);
  }
}

void limit_in_child(int wfd, const ResourceLimits& limits) {
  const auto set = [&](int resource, const std::optional<std::uint64_t>& value) {
    if (!value) return;
    const rlimit lim{static_cast<rlim_t>(*value), static_cast<rlim_t>(*value)};
    if (::setrlimit(resource, &lim) != 0) child_fail(wfd, kStageRlimit, errno);
  };
  set(RLIMIT_NPROC, limits.processes);
  set(RLIMIT_AS, limits.address_space);
  set(RLIMIT_NOFILE, limits.open_files);
  set(RLIMIT_FSIZE, limits.file_size);
  set(RLIMIT_RTTIME, limits.rt_time_us);
}

// The child's steps between fork and exec, in the order run_child takes them. Each is async-signal-safe: raw
// system calls on what was prepared before fork, no allocation; a failed step reports and exits.

// Killed when its parent (the kernel) dies, also if that happened before the prctl.
void die_with_parent_in_child(int wfd, pid_t parent) {
  if (::prctl(PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0) != 0) child_fail(wfd, kStagePdeathsig, errno);
  if (::getppid() != parent) ::_exit(127);  // the kernel died before the prctl took effect
}

// Into the service's cgroups first ("0": the writer itself), while still privileged and before anything it
// runs can fork: every process it ever makes is born in them. Then its process group or session.
void join_cgroups_and_session_in_child(int wfd, const SpawnSpec& spec) {
  for (const int procs : spec.cgroup_procs) {
    if (::write(procs, "0", 1) != 1) child_fail(wfd, kStageCgroup, errno);
  }
  switch (spec.session) {
    case Session::OwnProcessGroup:
      if (::setpgid(0, 0) != 0) child_fail(wfd, kStageSession, errno);
      break;
    case Session::NewSession:
      if (::setsid() < 0) child_fail(wfd, kStageSession, errno);
      break;
  }
}

// Puts every source fd at its target: moved out of the way first (they may collide with targets), then
// placed (dup2 clears CLOEXEC).
void place_fds_in_child(int wfd, const std::vector<std::pair<int, int>>& fds, int max_target) {
  std::array<int, 16> staged{};
  if (fds.size() > staged.size()) child_fail(wfd, kStageDupfd, EMFILE);
  for (std::size_t i = 0; i < fds.size(); ++i) {
    staged[i] = ::fcntl(fds[i].second, F_DUPFD_CLOEXEC, max_target + 1 + 16);
    if (staged[i] < 0) child_fail(wfd, kStageDupfd, errno);
  }
  for (std::size_t i = 0; i < fds.size(); ++i) {
    if (::dup2(staged[i], fds[i].first) < 0) child_fail(wfd, kStageDup2, errno);
  }
}

// Every other fd (above stderr) closes, except the report socket, which closes at exec.
// Every other fd (above stderr) closes, except the report socket `wfd` and the binary's fd `xfd` (above it),
// which close at exec.
void close_other_fds_in_child(int wfd, int xfd, const std::vector<std::pair<int, int>>& fds, int max_target) {
  for (int fd = 3; fd <= max_target; ++fd) {
    bool wanted = false;
    for (const auto& [target, source] : fds) wanted = wanted || target == fd;
    if (!wanted) ::close(fd);
  }
  // Closed now, not at exec: the fds the child makes before exec (the seccomp listener) must fit under its
  // RLIMIT_NOFILE, which a graph may set below the kernel's highest fd (max_open_files: 64 failed every
  // spawn with EMFILE once the kernel held more than 64 fds). The report socket stays open until exec.
  const auto close_between = [](int first, int last) {
    return first > last || ::syscall(SYS_close_range, first, last, 0) == 0;
  };
  if (!close_between(max_target + 1, wfd - 1) || !close_between(std::max(wfd + 1, max_target + 1), xfd - 1) ||
      ::syscall(SYS_close_range, std::max(xfd + 1, max_target + 1), ~0U, 0) != 0) {
    child_fail(wfd, kStageCloseRange, errno);
  }
}

// Its own uid and gid, no supplementary group: as root the service uid (gid = uid); without root its mapped
// subordinate ids, which it may take because it holds CAP_SETUID/CAP_SETGID in the user namespace it made
// (and loses every capability at exec: they are not 0 there). A change of credentials clears the parent-death
// signal, so it is set again.
void drop_uid_in_child(int wfd, const SpawnSpec& spec, pid_t parent) {
  uid_t uid = 0;
  gid_t gid = 0;
  if (spec.uid) {
    uid = *spec.uid;
    gid = *spec.uid;
  } else if (spec.mapped_ids && spec.isolation == Isolation::Namespaces) {
    uid = spec.mapped_ids->uid;
    gid = spec.mapped_ids->gid;
  } else {
    return;
  }
  if (::setgroups(0, nullptr) != 0 || ::setresgid(gid, gid, gid) != 0 || ::setresuid(uid, uid, uid) != 0) {
    child_fail(wfd, kStageSetuid, errno);
  }
  die_with_parent_in_child(wfd, parent);
}

// The filter last before exec; a supervised filter's listener goes to the parent on the report socket.
void install_seccomp_in_child(int wfd, const SpawnSpec& spec, Prepared& prep) {
  if (spec.seccomp == nullptr) return;
  int listener = -1;
  if (const int err = spec.seccomp->install_in_child(prep.seccomp_scratch.data(), ::getpid(), &listener);
      err != 0) {
    child_fail(wfd, kStageSeccomp, err);
  }
  if (listener >= 0) {
    child_report(wfd, kStageListener, 0, listener);
    ::close(listener);
  }
}

// The child from fork to exec.
[[noreturn]] void run_child(const SpawnSpec& spec, Prepared& prep, int report_write, pid_t parent) {
  // The report socket moves above the fd layout first, so that placing the fds cannot clobber it.
  int wfd = ::fcntl(report_write, F_DUPFD_CLOEXEC, prep.max_target + 1);
  if (wfd < 0) wfd = report_write;
  // Its network namespace before anything else (SpawnSpec::netns_fd), while the child still has the spawner's
  // credentials; the fd closes with the others it does not keep.
  if (spec.netns_fd >= 0 && ::setns(spec.netns_fd, CLONE_NEWNET) != 0) child_fail(wfd, kStageSetns, errno);
  // The binary is exec'ed by the fd the spawner opened (execveat AT_EMPTY_PATH): a service's uid then needs the
  // binary's execute bit only, no search right on the folders above it (a build in a 0700 home, run without
  // root by a subordinate uid), and the file exec'ed is the one the spawner named, whatever the path becomes.
  const int xfd = ::fcntl(prep.executable, F_DUPFD_CLOEXEC, wfd + 1);
  if (xfd < 0) child_fail(wfd, kStageDupfd, errno);
  die_with_parent_in_child(wfd, parent);
  join_cgroups_and_session_in_child(wfd, spec);
  place_fds_in_child(wfd, spec.fds, prep.max_target);
  close_other_fds_in_child(wfd, xfd, spec.fds, prep.max_target);
  if (spec.isolation == Isolation::Namespaces) isolate_in_child(wfd, spec);
  drop_uid_in_child(wfd, spec, parent);
  limit_in_child(wfd, spec.limits);  // after the uid: RLIMIT_NPROC counts the service uid's processes
  if (const int err = restrict_in_child(spec.landlock, spec.landlock_abi, xfd); err != 0) {
    child_fail(wfd, kStageLandlock, err);
  }
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  install_seccomp_in_child(wfd, spec, prep);
  ::syscall(SYS_execveat, xfd, "", prep.argv.data(), prep.envp.data(), AT_EMPTY_PATH);
  child_fail(wfd, kStageExec, errno);
}

// Everything the child needs, made before fork; refuses an fd layout the child could not place.
SysResult<Prepared> prepare(const SpawnSpec& spec) {
  Prepared prep;
  prep.argv.push_back(const_cast<char*>(spec.executable.c_str()));  // NOLINT: execve's signature
  for (const std::string& a : spec.args) prep.argv.push_back(const_cast<char*>(a.c_str()));  // NOLINT
  prep.argv.push_back(nullptr);
  for (const std::string& e : spec.env) prep.envp.push_back(const_cast<char*>(e.c_str()));  // NOLINT
  prep.envp.push_back(nullptr);
  if (spec.seccomp != nullptr) {
    prep.seccomp_scratch.resize(spec.seccomp->scratch_size());
  }
  for (const auto& [target, source] : spec.fds) {
    if (target < 0 || source < 0 || target > 1000) {
      return std::unexpected(SysError{"spawn: fd layout", EBADF});
    }
    prep.max_target = std::max(prep.max_target, target);
  }
  // Mapped ids are made in the user namespace of a spawner without root: with root (or without namespaces)
  // there would be none to map them in, and the child would silently keep the spawner's uid.
  if (spec.mapped_ids && (spec.isolation != Isolation::Namespaces || ::geteuid() == 0 || spec.uid)) {
    return std::unexpected(SysError{"spawn: mapped ids need Isolation::Namespaces and a spawner without root", EINVAL});
  }
  return prep;
}

// Reads the child's reports until exec closes the socket. A supervised child's exec is a boot call: it is let
// through here (the child's only one before exec).
SysResult<SeccompListener> await_exec(ChildProcess& child, int report_fd, const SpawnSpec& spec) {
  SeccompListener listener;
  bool exec_let_through = false;  // from then on the program runs: its notices are the supervisor's
  for (;;) {
    std::array<pollfd, 2> polls{pollfd{report_fd, POLLIN, 0}, pollfd{listener.fd(), POLLIN, 0}};
    const bool watch_listener = listener.valid() && !exec_let_through;
    const int rc = ::poll(polls.data(), watch_listener ? 2 : 1, -1);
    if (rc < 0 && errno == EINTR) continue;
    if (rc < 0) return last_error("poll(spawn)");
    if (watch_listener && (polls[1].revents & POLLIN) != 0) {
      auto notice = listener.receive();
      if (!notice) return std::unexpected(notice.error());
      if (*notice) {  // the child's only call between the filter and exec that the filter refers is the exec
        exec_let_through = (*notice)->pid == child.pid() && (syscall_number("execveat") == (*notice)->nr ||
                                                             syscall_number("execve") == (*notice)->nr);
        auto answered = exec_let_through ? listener.allow((*notice)->id) : listener.refuse((*notice)->id, EPERM);
        if (!answered) return std::unexpected(answered.error());
      }
    }
    if (polls[0].revents == 0) continue;
    std::array<int, 2> report{0, 0};
    iovec iov{report.data(), sizeof(report)};
    alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(int))> control{};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control.data();
    msg.msg_controllen = control.size();
    const ssize_t n = ::recvmsg(report_fd, &msg, MSG_CMSG_CLOEXEC);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return listener;  // closed at exec: the program runs
    int passed = -1;
    if (const cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr && c->cmsg_type == SCM_RIGHTS) {
      std::memcpy(&passed, CMSG_DATA(c), sizeof(int));
    }
    if (n == static_cast<ssize_t>(sizeof(report)) && report[0] == kStageListener && passed >= 0) {
      listener = SeccompListener(UniqueFd(passed));
      continue;
    }
    // Its user namespace is made: its maps are written before it goes on (it waits in read), so that it never
    // runs anything as an unmapped id. On failure it is killed (the caller drops `child`).
    if (n == static_cast<ssize_t>(sizeof(report)) && report[0] == kStageIdMap && report[1] == 0 && spec.mapped_ids) {
      if (passed >= 0) ::close(passed);
      if (auto mapped = write_id_maps(child.pid(), *spec.mapped_ids, spec.id_helpers); !mapped) {
        return std::unexpected(std::move(mapped.error()));
      }
      const int go = 0;
      if (::send(report_fd, &go, sizeof(go), MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof(go))) {
        return last_error("send(spawn: maps written)");
      }
      continue;
    }
    if (passed >= 0) ::close(passed);
    const auto stage = static_cast<std::size_t>(report[0]);
    (void)child.wait();
    return std::unexpected(SysError{stage < kStage.size() ? kStage[stage] : "spawn", report[1]});
  }
}

}  // namespace

SysResult<Spawned> spawn_supervised(const SpawnSpec& spec) {
  auto prep = prepare(spec);
  if (!prep) return std::unexpected(prep.error());
  // The binary, opened here with the spawner's rights (the child execs this fd: run_child).
  const UniqueFd executable(::open(spec.executable.c_str(), O_PATH | O_CLOEXEC));
  if (!executable) return std::unexpected(SysError{"open(the executable, O_PATH)", errno, spec.executable});
  prep->executable = executable.get();

  // The child's reports (a failed step, the seccomp listener) come back on a socket closed at exec.
  std::array<int, 2> report_pair{-1, -1};
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, report_pair.data()) != 0) {
    return last_error("socketpair(spawn)");
  }
  UniqueFd report_read(report_pair[0]);
  UniqueFd report_write(report_pair[1]);
  const pid_t parent = ::getpid();

  const pid_t pid = ::fork();
  if (pid < 0) {
    return last_error("fork");
  }
  if (pid == 0) run_child(spec, *prep, report_write.get(), parent);  // async-signal-safe calls only
  // ---- parent ----
  report_write.reset();
  auto child = ChildProcess::adopt(pid);
  if (!child) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    return std::unexpected(child.error());
  }
  auto listener = await_exec(*child, report_read.get(), spec);
  if (!listener) return std::unexpected(listener.error());
  return Spawned{.process = std::move(*child), .listener = std::move(*listener)};
}

SysResult<ChildProcess> spawn(const SpawnSpec& spec) {
  if (spec.seccomp != nullptr && spec.seccomp->enforcement() == Enforcement::Supervised) {
    return std::unexpected(SysError{"spawn: a supervised filter needs spawn_supervised", EINVAL});
  }
  auto spawned = spawn_supervised(spec);
  if (!spawned) return std::unexpected(spawned.error());
  return std::move(spawned->process);
}

SysResult<void> die_with_parent(pid_t parent, int sig) {
  if (::prctl(PR_SET_PDEATHSIG, sig, 0, 0, 0) != 0) return last_error("prctl(PR_SET_PDEATHSIG)");
  if (::getppid() != parent) ::_exit(1);  // the parent died before the prctl took effect
  return {};
}

SysResult<ChildProcess> fork_worker(const std::function<int()>& body) {
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) return last_error("fork");
  if (pid == 0) {
    if (!die_with_parent(parent, SIGTERM)) ::_exit(1);
    const int code = body();
    std::fflush(nullptr);
    ::_exit(code);
  }
  auto child = ChildProcess::adopt(pid);
  if (!child) (void)kill_and_reap_own_child(pid);  // no pidfd: nothing could wait for it
  return child;
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

SysResult<void> normal_priority(pid_t pid) {
  const sched_param param{};
  if (::sched_setscheduler(pid, SCHED_OTHER, &param) != 0) return last_error("sched_setscheduler(SCHED_OTHER)");
  if (::setpriority(PRIO_PROCESS, static_cast<id_t>(pid), 0) != 0) return last_error("setpriority");
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

bool signal_if(pid_t pid, int sig, const std::function<bool()>& still_same) {
  const UniqueFd fd(pidfd_open(pid, 0));
  if (!fd || !still_same()) return false;
  return pidfd_send_signal(fd.get(), sig) == 0;
}

bool kill_and_reap_own_child(pid_t pid) {
  if (pid <= 0) return false;
  // WNOWAIT: only asks whether it is ours (ECHILD otherwise) — before anything is signalled.
  siginfo_t info{};
  if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) != 0) return false;
  ::kill(pid, SIGKILL);
  while (::waitpid(pid, nullptr, 0) < 0 && errno == EINTR) {
  }
  return true;
}

SysResult<std::vector<pid_t>> own_children() {
  // Each thread has its own list (a child belongs to the thread that forked it; an orphan to the thread the
  // subreaper's exit handling picked), so all of them are read.
  DIR* tasks = ::opendir("/proc/self/task");
  if (tasks == nullptr) return last_error("opendir(/proc/self/task)");
  std::vector<pid_t> out;
  while (const dirent* entry = ::readdir(tasks)) {
    if (entry->d_name[0] < '0' || entry->d_name[0] > '9') continue;
    std::ifstream list(std::string("/proc/self/task/") + entry->d_name + "/children");
    long pid = 0;
    while (list >> pid) out.push_back(static_cast<pid_t>(pid));
  }
  ::closedir(tasks);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

SysResult<pid_t> session_of(pid_t pid) {
  const pid_t sid = ::getsid(pid);
  if (sid < 0) return last_error("getsid");
  return sid;
}

SysResult<UniqueFd> open_pagemap_without_frames(pid_t pid) {
  // capget/capset of the calling thread only (the raw calls: the C library has no wrapper, libcap would
  // change every thread).
  __user_cap_header_struct header{.version = _LINUX_CAPABILITY_VERSION_3, .pid = 0};
  std::array<__user_cap_data_struct, _LINUX_CAPABILITY_U32S_3> saved{};
  if (::syscall(SYS_capget, &header, saved.data()) != 0) return last_error("capget");
  constexpr unsigned kWord = CAP_SYS_ADMIN / 32;
  constexpr std::uint32_t kBit = 1U << (CAP_SYS_ADMIN % 32);
  const bool had = (saved[kWord].effective & kBit) != 0;
  if (had) {
    auto lowered = saved;
    lowered[kWord].effective &= ~kBit;
    if (::syscall(SYS_capset, &header, lowered.data()) != 0) return last_error("capset");
  }
  const std::string path = "/proc/" + std::to_string(pid) + "/pagemap";
  UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  const int open_errno = errno;
  if (had && ::syscall(SYS_capset, &header, saved.data()) != 0) return last_error("capset(restore)");
  if (!fd) return std::unexpected(SysError{"open(/proc/PID/pagemap)", open_errno});
  return fd;
}

std::optional<pid_t> thread_group_of(pid_t tid) {
  std::ifstream status("/proc/" + std::to_string(tid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("Tgid:", 0) == 0) {
      const long tgid = std::strtol(line.c_str() + 5, nullptr, 10);
      if (tgid > 0) return static_cast<pid_t>(tgid);
      return std::nullopt;
    }
  }
  return std::nullopt;
}

SysResult<TaskCpu> task_cpu(pid_t tid) {
  const std::string proc = "/proc/" + std::to_string(tid);
  // A /proc file's text (read_regular_file: small files that report size 0), its failure as a SysError.
  const auto text_of = [](const std::string& path) -> SysResult<std::string> {
    auto text = read_regular_file(path, 1024);
    if (text) return std::move(*text);
    if (text.error().kind == FileReadError::Kind::NoSuchFile) {
      return std::unexpected(SysError{"open(/proc/TID)", ENOENT});
    }
    return std::unexpected(text.error().sys.error != 0 ? text.error().sys : SysError{"read(/proc/TID)", EINVAL});
  };
  const auto schedstat = text_of(proc + "/schedstat");  // "<ns on a CPU> <ns waited on a run queue> <timeslices>"
  if (!schedstat) return std::unexpected(schedstat.error());
  unsigned long long ran = 0;
  if (std::sscanf(schedstat->c_str(), "%llu", &ran) != 1) {
    return std::unexpected(SysError{"parse(/proc/TID/schedstat)", EINVAL});
  }
  const auto stat = text_of(proc + "/stat");
  if (!stat) return std::unexpected(stat.error());
  // "<pid> (<comm>) <state> …": the command may hold spaces and parentheses, the state follows the last ')'.
  const std::size_t close = stat->rfind(')');
  if (close == std::string::npos || close + 2 >= stat->size()) {
    return std::unexpected(SysError{"parse(/proc/TID/stat)", EINVAL});
  }
  const char state = (*stat)[close + 2];
  return TaskCpu{.ran = Nanos{static_cast<std::int64_t>(ran)}, .runnable = state == 'R' || state == 'D',
                 .state = state};
}

}  // namespace rejuv::sys
