// Seccomp filters for service processes (DESIGN §7 "Protection"): no sockets, no ptrace, no process_vm_*,
// no signals to other processes, no exec. The BPF program is built (with libseccomp, which allocates) before
// the kernel forks; the child only copies it, patches its own pid in and loads it with prctl — all
// async-signal-safe, as required between fork and exec in a process that has DDS threads.
#pragma once

#include <linux/filter.h>
#include <sys/types.h>

#include <vector>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

enum class SeccompStage : std::uint8_t {
  // Installed by the kernel between fork and exec: everything of the service policy except the exec ban
  // (the service must still exec its binary).
  BeforeExec,
  // Installed by the service SDK right after exec, before it reads its channel: adds the exec ban.
  // Filters stack, so the service ends up with both.
  AfterExec,
};

class SeccompProgram {
 public:
  // The service policy for a stage. A denied call ends the process as if by SIGSYS (SECCOMP_RET_KILL_PROCESS,
  // no core dump): its parent, the kernel, sees that on the pidfd, counts a sandbox violation and contains it
  // (a rollback with SR on). An EPERM would leave the attempt invisible to the kernel.
  // Signals are allowed to the service's own pid only: the pid of the first incarnation (a restored image has
  // another pid, so its raise()/abort() also end it by SIGSYS).
  [[nodiscard]] static SysResult<SeccompProgram> service_policy(SeccompStage stage);

  // Loads the filter into the calling process (not async-signal-safe; for the SDK after exec).
  [[nodiscard]] SysResult<void> install() const;

  // Async-signal-safe load for a freshly forked child: copies the program into `scratch` (which the
  // parent sized with scratch_size() before the fork), patches the child's pid, sets RLIMIT_CORE 0 and
  // no_new_privs and loads it. Returns 0 or an errno.
  [[nodiscard]] int install_in_child(sock_filter* scratch, pid_t self) const noexcept;
  [[nodiscard]] std::size_t scratch_size() const { return filter_.size(); }
  [[nodiscard]] std::size_t instructions() const { return filter_.size(); }

 private:
  std::vector<sock_filter> filter_;
};

}  // namespace rejuv::sys
