// Child processes owned by the kernel (DESIGN §2, §7): spawned with a fixed fd layout, their own process
// group, a parent-death signal and an optional seccomp filter and uid; watched through a pidfd; killed and
// reaped when their handle goes away, so that no process is ever left behind.
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/seccomp.hpp"

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
  // an image a service reports only if it really is the kernel's child (DESIGN §7).
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

struct SpawnSpec {
  std::string executable{};                      // path; not searched in PATH
  std::vector<std::string> args{};               // argv[1..]
  std::vector<std::string> env{};                // "NAME=value"; the child gets exactly these
  std::vector<std::pair<int, int>> fds{};        // {fd in the child, fd in the parent}: the only fds it keeps
  const SeccompProgram* seccomp = nullptr;       // BeforeExec-stage filter, or none
  std::optional<uid_t> uid{};                    // drop to this uid/gid (kernel runs as root)
  bool own_process_group = true;                 // terminal signals go to the kernel only
};

// fork + exec with every step checked; an exec failure in the child comes back as an error value here
// (through a close-on-exec pipe), not as a mysterious exit code.
[[nodiscard]] SysResult<ChildProcess> spawn(const SpawnSpec& spec);

// Makes this process the reaper of its orphaned descendants (PR_SET_CHILD_SUBREAPER), so that images
// double-forked by services become the kernel's children (DESIGN §7).
[[nodiscard]] SysResult<void> become_subreaper();

// ---- images (DESIGN §7) ----
// Forks the calling process with clone(CLONE_PARENT): the child's parent is the caller's parent, so a
// service's image is the kernel's child at once (one fork instead of DESIGN §7's double fork, and nothing
// for the service to reap). Returns the child's pid in the caller and 0 in the child. Only for a process
// whose other threads are parked (the child has the calling thread only; no atfork handlers run).
[[nodiscard]] SysResult<pid_t> fork_sibling();
// PR_SET_DUMPABLE 0: no core dump, no ptrace or /proc/<pid>/mem access by other processes of its uid.
[[nodiscard]] SysResult<void> make_non_dumpable();

// ---- CPU placement (DESIGN §6) ----
// Pins the calling thread to one CPU: `cpu`, or the one it runs on now. Threads and processes it creates
// afterwards inherit the mask. Returns the CPU. EINVAL: `cpu` is not one this process may use (out of
// range, offline, or outside its cpuset).
[[nodiscard]] SysResult<int> pin_to_one_cpu(std::optional<int> cpu);
// Gives `pid` the lowest CFS priority (nice 19), e.g. before killing it. A SIGKILL still makes its victim run
// its exit — tearing down its address space, ≈ 0.09 ms here — at once, whatever its priority (measured:
// 8 kills 0.68 ms, 0.69 ms at nice 19), so a rollback kills its victims only after (idle_priority).
[[nodiscard]] SysResult<void> lower_priority(pid_t pid);
// Puts `pid` under SCHED_IDLE: it then runs only when no other task on its CPU can. Unlike a signal, this
// does not wake it (a rollback's retired incarnations, DESIGN §7).
[[nodiscard]] SysResult<void> idle_priority(pid_t pid);

// Counts the live processes whose parent is `parent` (from /proc), for leak checks in tests.
[[nodiscard]] SysResult<int> count_children(pid_t parent);

}  // namespace rejuv::sys
