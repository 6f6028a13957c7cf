// Child processes owned by the kernel (docs/design.md §2, §7): spawned with a fixed fd layout, their own process
// group, a parent-death signal and an optional seccomp filter and uid; watched through a pidfd; killed and
// reaped when their handle goes away, so that no process is ever left behind.
#pragma once

#include <cerrno>

#include <sys/types.h>

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rejuv/core/time.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/landlock.hpp"
#include "rejuv/sys/seccomp.hpp"
#include "rejuv/sys/subid.hpp"

namespace rejuv::sys {

struct ExitStatus {
  enum class How : std::uint8_t { Exited, Signaled };
  How how = How::Exited;
  int value = 0;  // exit code or signal number
  [[nodiscard]] bool success() const { return how == How::Exited && value == 0; }
  [[nodiscard]] std::string to_string() const;  // "exited with 3", "killed by SIGKILL"
};

// A child process: pid + pidfd. Move-only; the destructor kills (SIGKILL) and reaps it unless it was
// already reaped. Reaping twice is safe.
class ChildProcess {
 public:
  ChildProcess() = default;
  // Takes charge of an existing child (or, with the kernel as subreaper, an adopted descendant).
  [[nodiscard]] static SysResult<ChildProcess> adopt(pid_t pid);
  // The same, but only if `pid` is this process's own child (ECHILD otherwise): the kernel takes charge of
  // an image a service reports only if it really is the kernel's child (docs/design.md §7).
  [[nodiscard]] static SysResult<ChildProcess> adopt_child(pid_t pid);
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ChildProcess(ChildProcess&& other) noexcept;
  ChildProcess& operator=(ChildProcess&& other) noexcept;
  ~ChildProcess() { kill_and_reap(); }

  [[nodiscard]] pid_t pid() const { return pid_; }
  // Readable (poll) when the process has exited.
  [[nodiscard]] int pidfd() const { return pidfd_.get(); }
  [[nodiscard]] bool running() const { return pid_ > 0 && !status_; }
  [[nodiscard]] const std::optional<ExitStatus>& status() const { return status_; }

  // Reaps it if it has exited; nullopt while it runs.
  [[nodiscard]] SysResult<std::optional<ExitStatus>> try_wait();
  // Whether it has been stopped (SIGSTOP, SIGTSTP …) since the last look: each stop is reported once.
  [[nodiscard]] SysResult<bool> stopped_since_last_look();
  [[nodiscard]] SysResult<ExitStatus> wait();
  [[nodiscard]] SysResult<void> signal(int sig) const;
  // SIGKILL (if still running) and reap. Idempotent.
  void kill_and_reap() noexcept;

 private:
  ChildProcess(pid_t pid, UniqueFd pidfd) : pid_(pid), pidfd_(std::move(pidfd)) {}
  pid_t pid_ = -1;
  UniqueFd pidfd_;
  std::optional<ExitStatus> status_;
};

// Resource limits of a spawned process (setrlimit, soft = hard, so it cannot raise them). Unset: inherited.
struct ResourceLimits {
  std::optional<std::uint64_t> processes{};       // RLIMIT_NPROC: processes of its (real) uid
  std::optional<std::uint64_t> address_space{};   // RLIMIT_AS, bytes
  std::optional<std::uint64_t> open_files{};      // RLIMIT_NOFILE
  std::optional<std::uint64_t> file_size{};       // RLIMIT_FSIZE, bytes (memfds count: shmem files)
  std::optional<std::uint64_t> rt_time_us{};      // RLIMIT_RTTIME, µs at a real-time policy without blocking
};

// What a spawned process is cut off from (docs/design.md §7 "Protection").
enum class Isolation : std::uint8_t {
  None,
  // An empty network namespace (no interface up: no address, loopback included, reaches anything), an IPC
  // namespace of its own, and a mount namespace in which every mount is read-only, nosuid and nodev. Root
  // makes them directly; anyone else through a new user namespace where the system allows that.
  Namespaces,
};

// Where it stands towards terminals and job control.
enum class Session : std::uint8_t {
  OwnProcessGroup,  // terminal signals (Ctrl-C) go to the kernel only
  NewSession,       // setsid: also no controlling terminal, and its session id marks every process it makes
};

struct SpawnSpec {
  std::string executable{};                      // path; not searched in PATH
  std::vector<std::string> args{};               // argv[1..]
  std::vector<std::string> env{};                // "NAME=value"; the child gets exactly these
  std::vector<std::pair<int, int>> fds{};        // {fd in the child, fd in the parent}: the only fds it keeps
  const SeccompProgram* seccomp = nullptr;       // the service filter, or none
  std::optional<uid_t> uid{};                    // drop to this uid/gid (kernel runs as root)
  // Without root, with Isolation::Namespaces: the ids it runs as outside its user namespace (subordinate ids
  // of the spawner's user, subid.hpp). The child waits after unshare(CLONE_NEWUSER) until the spawner has
  // written its maps with `id_helpers`' newuidmap/newgidmap, then becomes them; never the spawner's uid.
  std::optional<MappedIds> mapped_ids{};
  SubidSources id_helpers{};
  Session session = Session::OwnProcessGroup;
  Isolation isolation = Isolation::None;
  ResourceLimits limits{};
  std::span<const int> cgroup_procs{};           // cgroup.procs files (ServiceCgroup::join_fds): joined before exec
  // Landlock (rejuv/sys/landlock.hpp): what the process may open, applied after the limits and before the
  // filter; none when landlock_abi is 0.
  std::vector<LandlockRule> landlock{};
  int landlock_abi = 0;
  // A network namespace to join (an fd of /run/netns/<name>, kept open by the spawner until spawn returns): the
  // child's first step is setns(CLONE_NEWNET) into it, and Isolation::Namespaces then makes no network namespace
  // of its own (a network-facing service: the link between hosts, docs/sandbox.md). -1: none. Needs root.
  int netns_fd = -1;
  // Isolation::Namespaces keeps the spawner's network namespace instead of making an empty one (the link of a
  // host whose uplink is one of the spawner's own interfaces). Ignored when netns_fd is set.
  bool keep_network = false;
};

// A spawned process and, when its filter is supervised, the listener for the calls it refers to the spawner.
struct Spawned {
  ChildProcess process;
  SeccompListener listener;
};

// fork + exec with every step checked; an exec failure in the child comes back as an error value here
// (through a close-on-exec socket), not as a mysterious exit code. With a supervised filter the exec itself is
// a boot call the spawner lets through (seccomp.hpp); spawn() is for unsupervised filters or none.
[[nodiscard]] SysResult<Spawned> spawn_supervised(const SpawnSpec& spec);
[[nodiscard]] SysResult<ChildProcess> spawn(const SpawnSpec& spec);

// The calling process gets `sig` when its parent dies (PR_SET_PDEATHSIG), or ends at once (exit 1) if the
// parent `parent` is already gone: a worker forked by a command never outlives the command.
[[nodiscard]] SysResult<void> die_with_parent(pid_t parent, int sig);

// Forks a worker process of a command that runs `body` and exits with what it returns; the caller gets the
// worker as its child. The worker dies with the caller (SIGTERM: die_with_parent) and flushes stdio before it
// exits. Fork from a single-threaded process only (the worker has the calling thread alone).
[[nodiscard]] SysResult<ChildProcess> fork_worker(const std::function<int()>& body);

// Makes this process the reaper of its orphaned descendants (PR_SET_CHILD_SUBREAPER), so that images
// double-forked by services become the kernel's children (docs/design.md §7).
[[nodiscard]] SysResult<void> become_subreaper();

// ---- images (docs/design.md §7) ----
// Forks the calling process with clone(CLONE_PARENT): the child's parent is the caller's parent, so a
// service's image is the kernel's child at once (one fork instead of docs/design.md §7's double fork, and nothing
// for the service to reap). Returns the child's pid in the caller and 0 in the child. Only for a process
// whose other threads are parked (the child has the calling thread only; no atfork handlers run).
[[nodiscard]] SysResult<pid_t> fork_sibling();
// PR_SET_DUMPABLE 0: no core dump, no ptrace or /proc/<pid>/mem access by other processes of its uid.
[[nodiscard]] SysResult<void> make_non_dumpable();

// ---- CPU placement (docs/design.md §6) ----
// Pins the calling thread to one CPU: `cpu`, or the one it runs on now. Threads and processes it creates
// afterwards inherit the mask. Returns the CPU. EINVAL: `cpu` is not one this process may use (out of
// range, offline, or outside its cpuset).
[[nodiscard]] SysResult<int> pin_to_one_cpu(std::optional<int> cpu);
// Puts `pid` under SCHED_IDLE: it then runs only when no other task on its CPU can. Unlike a signal, this
// does not wake it (a rollback's retired incarnations, docs/design.md §7). A SIGKILL makes its victim run its exit —
// tearing down its address space, ≈ 0.09 ms here — at once, whatever its priority (measured: 8 kills
// 0.68 ms, 0.69 ms at nice 19), so a rollback kills its victims only after, at a safe point.
[[nodiscard]] SysResult<void> idle_priority(pid_t pid);
// SCHED_OTHER at nice 0 (undoes idle_priority).
[[nodiscard]] SysResult<void> normal_priority(pid_t pid);

// Sends `sig` to `pid` through a pidfd, only if `still_same()` holds once the pidfd is open (so that a pid
// reused meanwhile is never signalled). False when the process is gone or the check failed.
[[nodiscard]] bool signal_if(pid_t pid, int sig, const std::function<bool()>& still_same);

// The pids of this process's own children (every thread's, from /proc/self/task/*/children), ascending.
[[nodiscard]] SysResult<std::vector<pid_t>> own_children();
// Kills and reaps a child of this process by pid, without a pidfd: the fallback when no fd is left to open one
// (EMFILE). An unreaped child's pid cannot be reused, so the pid names the same process until the wait below;
// the wait is by that pid only. False when `pid` is not a child of this process (nothing is signalled).
[[nodiscard]] bool kill_and_reap_own_child(pid_t pid);
// True for the errors of a process out of file descriptors (its own limit or the system's).
[[nodiscard]] inline bool out_of_fds(int error) { return error == EMFILE || error == ENFILE; }

// The session id of `pid` (a service is a session of its own; setsid is not on its allow-list, so every
// process it makes stays in it).
[[nodiscard]] SysResult<pid_t> session_of(pid_t pid);

// /proc/PID/pagemap of another process, opened so that its readers see no physical frame numbers: the kernel
// shows them only to an opener with CAP_SYS_ADMIN (checked against the credentials the file was opened with),
// so that capability is left out of this thread's effective set for the open (CAP_SYS_PTRACE stays: the
// target is not dumpable). The service that receives the fd learns where its pages are written, not where
// they are in physical memory (a Rowhammer aid).
[[nodiscard]] SysResult<UniqueFd> open_pagemap_without_frames(pid_t pid);

// The process (thread group id) a thread belongs to, from /proc/TID/status; nullopt when it is gone.
[[nodiscard]] std::optional<pid_t> thread_group_of(pid_t tid);

// What the scheduler gives a thread (for a process's pid, its main thread): the time it ran on a CPU since it was
// born (/proc/TID/schedstat) and whether it is runnable now, as the load average counts it: running or waiting
// on a run queue for a CPU (state R of /proc/TID/stat), or in an uninterruptible wait inside the OS (D: a lock
// whose holder waits for a CPU, memory, a vfork child) — the machine's doing — rather than asleep by its own
// call (S), stopped (T) or dead. The run-queue time schedstat also shows counts a wait only once it is over: it
// says nothing of a thread that is waiting still.
struct TaskCpu {
  Nanos ran{0};
  bool runnable = false;
  char state = '?';  // the state letter of /proc/TID/stat, for messages
};
[[nodiscard]] SysResult<TaskCpu> task_cpu(pid_t tid);

// Counts the live processes whose parent is `parent` (from /proc), for leak checks in tests.
[[nodiscard]] SysResult<int> count_children(pid_t parent);

}  // namespace rejuv::sys
