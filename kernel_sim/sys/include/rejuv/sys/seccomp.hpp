// The services' system-call allow-list (docs/design.md §7 "Protection (containment)", docs/sandbox.md).
//
// One table (service_syscalls(), seccomp.cpp) is the source of truth: every call a service may make, with the
// argument checks that matter and the reason it is needed. Everything else is refused. The kernel installs
// the filter between fork and exec, so it binds any executable a graph names, and images inherit it.
//
// Two kinds of entry:
//   - Always: the calls of a running service (its channel, memory, time, images, workers).
//   - WhileBooting: what exec, the dynamic loader and the SDK's start-up need (open, exec, executable
//     mappings …) and a booted service never does again. The filter sends them to the kernel (seccomp user
//     notification), which lets them continue while the service has not yet said Ready and treats them as
//     a violation afterwards: "no open after boot" and W^X hold for any executable, not only SDK code, and
//     the decision rests on what the kernel knows, not on the caller's arguments (no TOCTOU).
// A call outside the table also goes to the kernel, which learns its name, counts the violation, kills the
// process and contains it (a rollback). A process without a supervisor (tests) uses the standalone form:
// boot calls allowed, everything else ends the process as if by SIGSYS.
//
// The BPF program is built with libseccomp (binary-tree layout) before the kernel forks; the child only copies
// it, patches its own pid in and loads it — async-signal-safe, as required between fork and exec in a process
// that has DDS threads.
#pragma once

#include <linux/filter.h>
#include <sys/types.h>

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// When an entry of the allow-list holds.
enum class Allowance : std::uint8_t {
  Always,        // at any time
  WhileBooting,  // until the service is ready; the supervisor decides (seccomp user notification)
  Enosys,        // refused with ENOSYS, not a violation (clone3: glibc falls back to clone, whose flags are checked)
};

// The argument checks of an entry (on register values only: seccomp cannot read memory).
enum class ArgCheck : std::uint8_t {
  None,
  SelfPid,         // arg 0 is the calling process's own pid (signals only to itself; supervised: checked by the kernel)
  CloneFlags,      // arg 0 is exactly the image fork's (CLONE_PARENT|SIGCHLD) or a thread's flags
  ExecOnlyBooting, // mmap/mprotect: PROT_EXEC only while booting (W^X once booted)
  IoctlCodes,      // arg 1 is one of the request codes the image code uses (userfaultfd, PAGEMAP_SCAN, TCGETS)
  PrctlOptions,    // arg 0 is one of the options a running service uses; any other only while booting
  EmptyPathStat,   // newfstatat on an fd (AT_EMPTY_PATH); a path only while booting
  FcntlCommands,   // arg 1 is a command that aims no signal: no F_SETOWN(_EX), F_SETSIG, F_SETLEASE, F_NOTIFY, and
                   // F_SETFL only without O_ASYNC (SIGIO reaches every process of a uid or a process group)
  // Boot calls whose arguments the kernel checks too (no trusted boot phase). A failed check while
  // booting is NoticeKind::RefusedAtBoot; after Ready every such call is a violation anyway.
  ReadOnlyOpen,    // open (flags arg 1) / openat (flags arg 2): read-only, nothing created, truncated or appended
                   // (the time page's fd reopened O_RDWR through /proc/self/fd/4 was the attack)
  OwnLimitsRead,   // prlimit64: pid 0 or the caller's own, new limit NULL (reading its own limits only;
                   // prlimit64(kernel, RLIMIT_CPU, {1, 1}) killed the kernel)
  SpawnerOnly,     // execve/execveat: the kernel's own exec of the service's binary is let through by the spawner
                   // (process.cpp await_exec); any exec the service makes is refused
  SocketDomains,   // socket: arg 0 is AF_INET or AF_NETLINK (a network-facing service's UDP and its interface list)
  NetworkIoctlCodes, // ioctl: arg 1 is an interface query of a network-facing service (SIOCGIFINDEX)
};

struct SyscallRule {
  std::string_view name;
  Allowance allowance = Allowance::Always;
  ArgCheck check = ArgCheck::None;
  std::string_view reason;
};

// The allow-list, in the order docs/sandbox.md shows it.
[[nodiscard]] std::span<const SyscallRule> service_syscalls();
// What a network-facing service (the link between hosts, docs/sandbox.md "The link") may call beyond
// service_syscalls(): its own UDP sockets (Cyclone DDS) and the interface list, nothing else of the network.
[[nodiscard]] std::span<const SyscallRule> network_syscalls();

// How a refused call is handled.
enum class Enforcement : std::uint8_t {
  // The kernel supervises: WhileBooting calls and calls outside the list are sent to it (user notification).
  Supervised,
  // No supervisor (tests, tools): WhileBooting calls are allowed, anything outside the list ends the process
  // (SECCOMP_RET_KILL_PROCESS, seen by its parent as SIGSYS).
  Standalone,
};

class SeccompProgram {
 public:
  [[nodiscard]] static SysResult<SeccompProgram> service_policy(Enforcement enforcement);
  // service_policy plus network_syscalls(): given only to a network-facing service (the link between hosts).
  [[nodiscard]] static SysResult<SeccompProgram> network_service_policy(Enforcement enforcement);

  // Loads the filter into the calling process (not async-signal-safe). Supervised: returns the listener fd.
  [[nodiscard]] SysResult<UniqueFd> install() const;

  // Async-signal-safe load for a freshly forked child: copies the program into `scratch` (sized with
  // scratch_size() before the fork), patches the child's pid, sets RLIMIT_CORE 0 and no_new_privs and loads
  // it. Supervised: *listener receives the listener fd. Returns 0 or an errno.
  [[nodiscard]] int install_in_child(sock_filter* scratch, pid_t self, int* listener) const noexcept;
  [[nodiscard]] std::size_t scratch_size() const { return filter_.size(); }
  [[nodiscard]] std::size_t instructions() const { return filter_.size(); }
  [[nodiscard]] Enforcement enforcement() const { return enforcement_; }

 private:
  [[nodiscard]] static SysResult<SeccompProgram> build(Enforcement enforcement, bool network);
  std::vector<sock_filter> filter_;
  Enforcement enforcement_ = Enforcement::Standalone;
};

// ---- the supervisor's side (the kernel) ----

// One call a supervised process made that the filter sent to its supervisor; the process waits in the call.
struct SeccompNotice {
  std::uint64_t id = 0;
  pid_t pid = 0;  // the calling thread, in the supervisor's pid namespace
  pid_t tgid = 0; // its process (thread group id); 0 when it was gone before it could be read
  int nr = -1;
  std::array<std::uint64_t, 6> args{};
};

// What the table says of a notice.
enum class NoticeKind : std::uint8_t {
  BootCall,      // a WhileBooting call (or the boot-only form of an Always call): fine until the service is ready
  SignalToSelf,  // kill/tgkill whose target is the caller's own process (any of its threads): fine at any time
  RefusedAtBoot, // a boot call with arguments no start-up needs (ArgCheck ReadOnlyOpen, OwnLimitsRead,
                 // SpawnerOnly, a prctl other than PR_SET_DUMPABLE 0): while booting refused with EPERM and counted
                 // as a violation of the service (it runs on: nothing was done); after Ready, Forbidden
  Forbidden,     // outside the allow-list: a sandbox violation
};
[[nodiscard]] NoticeKind classify(const SeccompNotice& notice);

// The call's name ("socket", "io_uring_setup"), or "syscall <nr>".
[[nodiscard]] std::string syscall_name(int nr);
// The call's number for this architecture, if it has one.
[[nodiscard]] std::optional<int> syscall_number(std::string_view name);

// The listener fd of a filter (readable when a notice waits).
class SeccompListener {
 public:
  SeccompListener() = default;
  explicit SeccompListener(UniqueFd fd) : fd_(std::move(fd)) {}
  [[nodiscard]] int fd() const { return fd_.get(); }
  [[nodiscard]] bool valid() const { return fd_.valid(); }
  void close() { fd_.reset(); }
  // The next notice, or nullopt if none waits (or its process died before it was read).
  [[nodiscard]] SysResult<std::optional<SeccompNotice>> receive() const;
  // Lets the call run as if no filter had seen it (only for decisions that do not depend on pointer arguments).
  [[nodiscard]] SysResult<void> allow(std::uint64_t id) const;
  // Fails the call with `error` (an errno).
  [[nodiscard]] SysResult<void> refuse(std::uint64_t id, int error) const;
  // Whether the notice's process still waits in that call (its pid was not reused).
  [[nodiscard]] bool still_waiting(std::uint64_t id) const;

 private:
  UniqueFd fd_;
};

}  // namespace rejuv::sys
