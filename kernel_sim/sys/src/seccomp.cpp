#include "rejuv/sys/seccomp.hpp"

#include <fcntl.h>
#include <linux/seccomp.h>
#include <seccomp.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <memory>

namespace rejuv::sys {

namespace {

// Placeholder for "my own pid" in argument comparisons; patched after the fork (a pid never has this value:
// it exceeds PID_MAX_LIMIT = 2^22).
constexpr std::uint32_t kSelfPidSentinel = 0x7EAD5E1FU;

struct CtxDeleter {
  void operator()(void* ctx) const { seccomp_release(ctx); }
};

}  // namespace

SysResult<SeccompProgram> SeccompProgram::service_policy(SeccompStage stage) {
  std::unique_ptr<void, CtxDeleter> ctx(seccomp_init(SCMP_ACT_ALLOW));
  if (!ctx) {
    return std::unexpected(SysError{"seccomp_init", ENOMEM});
  }
  // A call that tries to leave the sandbox ends the process (SIGSYS) instead of failing with EPERM: the
  // kernel, its parent, sees the death on its pidfd, counts a sandbox violation and contains it like any
  // lost service (a rollback with SR on). An EPERM would be invisible to the kernel and leave a compromised
  // process running that probes on (DESIGN §7 "Protection", §11).
  const auto deny = [&](int syscall) { return seccomp_rule_add(ctx.get(), SCMP_ACT_KILL_PROCESS, syscall, 0); };
  const auto deny_unless_self = [&](int syscall) {
    return seccomp_rule_add(ctx.get(), SCMP_ACT_KILL_PROCESS, syscall, 1,
                            SCMP_A0(SCMP_CMP_NE, kSelfPidSentinel));
  };
  int rc = 0;
  // No network and no new sockets of any family: a service reaches the world only through its channel.
  for (const int sc : {SCMP_SYS(socket), SCMP_SYS(socketpair), SCMP_SYS(connect), SCMP_SYS(bind),
                       SCMP_SYS(listen), SCMP_SYS(accept), SCMP_SYS(accept4)}) {
    rc |= deny(sc);
  }
  // No debugging or memory access of other processes, no stealing their fds.
  for (const int sc : {SCMP_SYS(ptrace), SCMP_SYS(process_vm_readv), SCMP_SYS(process_vm_writev),
                       SCMP_SYS(pidfd_getfd), SCMP_SYS(pidfd_open), SCMP_SYS(pidfd_send_signal),
                       SCMP_SYS(kcmp), SCMP_SYS(tkill)}) {
    rc |= deny(sc);
  }
  // Signals only to itself (raise/abort use tgkill on their own pid).
  for (const int sc : {SCMP_SYS(kill), SCMP_SYS(tgkill), SCMP_SYS(rt_sigqueueinfo), SCMP_SYS(rt_tgsigqueueinfo)}) {
    rc |= deny_unless_self(sc);
  }
  if (stage == SeccompStage::AfterExec) {
    rc |= deny(SCMP_SYS(execve));
    rc |= deny(SCMP_SYS(execveat));
  }
  if (rc != 0) {
    return std::unexpected(SysError{"seccomp_rule_add", -rc});
  }
  // libseccomp 2.5 exports to an fd only: go through a memfd.
  UniqueFd mem(::memfd_create("rejuv-seccomp", MFD_CLOEXEC));
  if (!mem) {
    return last_error("memfd_create");
  }
  if (const int erc = seccomp_export_bpf(ctx.get(), mem.get()); erc != 0) {
    return std::unexpected(SysError{"seccomp_export_bpf", -erc});
  }
  const off_t size = ::lseek(mem.get(), 0, SEEK_END);
  if (size <= 0 || size % static_cast<off_t>(sizeof(sock_filter)) != 0) {
    return std::unexpected(SysError{"seccomp_export_bpf", EINVAL});
  }
  SeccompProgram program;
  program.filter_.resize(static_cast<std::size_t>(size) / sizeof(sock_filter));
  if (::pread(mem.get(), program.filter_.data(), static_cast<std::size_t>(size), 0) != size) {
    return last_error("pread");
  }
  return program;
}

SysResult<void> SeccompProgram::install() const {
  std::vector<sock_filter> copy = filter_;
  if (const int err = install_in_child(copy.data(), ::getpid()); err != 0) {
    return std::unexpected(SysError{"prctl(PR_SET_SECCOMP)", err});
  }
  return {};
}

int SeccompProgram::install_in_child(sock_filter* scratch, pid_t self) const noexcept {
  for (std::size_t i = 0; i < filter_.size(); ++i) {
    scratch[i] = filter_[i];
    if (scratch[i].k == kSelfPidSentinel) {
      scratch[i].k = static_cast<std::uint32_t>(self);
    }
  }
  // No core dump when the filter ends the process (SIGSYS dumps core by default): nothing of a service's
  // memory is written to disk, and nothing is left behind in the working directory.
  const rlimit no_core{0, 0};
  if (::setrlimit(RLIMIT_CORE, &no_core) != 0) {
    return errno;
  }
  if (::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) {
    return errno;
  }
  sock_fprog prog{static_cast<unsigned short>(filter_.size()), scratch};
  if (::prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, &prog, 0, 0) != 0) {
    return errno;
  }
  return 0;
}

}  // namespace rejuv::sys
