#include "rejuv/sys/seccomp.hpp"

#include "rejuv/sys/process.hpp"

#include <fcntl.h>
#include <linux/fs.h>
#include <linux/seccomp.h>
#include <linux/sockios.h>
#include <linux/userfaultfd.h>
#include <poll.h>
#include <sched.h>
#include <seccomp.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <memory>

// libseccomp's SCMP_A0…SCMP_A5 argument macros are C compound literals that leave a field to its default:
// g++ accepts them quietly, clang (the fuzz preset) warns. The macros are libseccomp's documented API.
#ifdef __clang__
#pragma clang diagnostic ignored "-Wc99-extensions"
#pragma clang diagnostic ignored "-Wmissing-field-initializers"
#endif

namespace rejuv::sys {

namespace {

// Placeholder for "my own pid" in argument comparisons; patched after the fork (a pid never has this value:
// it exceeds PID_MAX_LIMIT = 2^22).
constexpr std::uint32_t kSelfPidSentinel = 0x7EAD5E1FU;

// PAGEMAP_SCAN (Linux 6.7): the request code memory_image uses to find the pages written since an image
// (<linux/fs.h> of Debian 12 predates it).
constexpr unsigned long kPagemapScan = 0xC0606610UL;  // _IOWR('f', 16, struct pm_scan_arg)

// The image fork (sys::fork_sibling) and a thread of the C library (pthread_create's clone fallback).
constexpr std::uint64_t kImageForkFlags = CLONE_PARENT | SIGCHLD;
constexpr std::uint64_t kThreadFlags = CLONE_VM | CLONE_FS | CLONE_FILES | CLONE_SIGHAND | CLONE_THREAD |
                                       CLONE_SYSVSEM | CLONE_SETTLS | CLONE_PARENT_SETTID | CLONE_CHILD_CLEARTID;

// The ioctl request codes a running service may use: userfaultfd set-up and write-protection, PAGEMAP_SCAN
// (images by written pages, memory_image.cpp), and TCGETS, which the C library's isatty() asks of fds 1-2.
constexpr std::array<unsigned long, 5> kIoctlCodes{UFFDIO_API, UFFDIO_REGISTER, UFFDIO_WRITEPROTECT,
                                                   kPagemapScan, TCGETS};
// The prctl options a running service may use (any other only while booting): read its own dumpable flag and
// name, and set the name of a worker thread.
constexpr std::array<int, 3> kPrctlOptions{PR_GET_DUMPABLE, PR_SET_NAME, PR_GET_NAME};
// The fcntl commands a running service may use: duplicating fds, their flags, memfd seals. F_SETFL is allowed
// only without O_ASYNC (checked apart). Every command that aims a signal is outside the list: F_SETOWN,
// F_SETOWN_EX and F_SETSIG choose who gets SIGIO/SIGURG (a negative owner is a whole process group, and with
// F_SETSIG any signal: SIGKILL or SIGSTOP to the service's own images, or to the kernel where it shares its
// uid), F_SETLEASE and F_NOTIFY make the kernel signal the caller later; the owner is a property of the open
// file, which a frozen image shares with the live incarnation, so it would outlive a rollback.
constexpr std::array<int, 7> kFcntlCommands{F_DUPFD, F_DUPFD_CLOEXEC, F_GETFD, F_SETFD, F_GETFL, F_ADD_SEALS,
                                            F_GET_SEALS};

// The allow-list (docs/design.md §7 "Protection"; docs/sandbox.md prints it). x86-64 names, as libseccomp spells
// them; a name this architecture lacks is skipped.
constexpr std::array kServiceRules{
    // ---- the channel to the kernel (a Unix SOCK_SEQPACKET pair it was given; no socket can be made) ----
    SyscallRule{"read", Allowance::Always, ArgCheck::None, "channel, resume socket, time page fd"},
    SyscallRule{"write", Allowance::Always, ArgCheck::None, "stdout/stderr (pipes the kernel logs), channel"},
    SyscallRule{"readv", Allowance::Always, ArgCheck::None, "the C library's stdio"},
    SyscallRule{"writev", Allowance::Always, ArgCheck::None, "the C library's stdio"},
    SyscallRule{"sendmsg", Allowance::Always, ArgCheck::None, "frames and fds on the channel"},
    SyscallRule{"recvmsg", Allowance::Always, ArgCheck::None, "frames and fds on the channel"},
    SyscallRule{"sendto", Allowance::Always, ArgCheck::None, "send() on the channel (no address: connected pair)"},
    SyscallRule{"recvfrom", Allowance::Always, ArgCheck::None, "recv() on the channel"},
    SyscallRule{"recvmmsg", Allowance::Always, ArgCheck::None, "batched receive of frames"},
    SyscallRule{"sendmmsg", Allowance::Always, ArgCheck::None, "batched send of frames"},
    SyscallRule{"poll", Allowance::Always, ArgCheck::None, "waiting for the channel with a deadline"},
    SyscallRule{"ppoll", Allowance::Always, ArgCheck::None, "waiting for the channel with a deadline"},
    SyscallRule{"close", Allowance::Always, ArgCheck::None, "fds the kernel passed (resume sockets, memfds)"},
    SyscallRule{"close_range", Allowance::Always, ArgCheck::None, "dropping fds a restored image must not keep"},
    SyscallRule{"dup", Allowance::Always, ArgCheck::None, "moving a new channel to fd 3 (a restored image)"},
    SyscallRule{"dup2", Allowance::Always, ArgCheck::None, "moving a new channel to fd 3 (a restored image)"},
    SyscallRule{"dup3", Allowance::Always, ArgCheck::None, "moving a new channel to fd 3 (a restored image)"},
    SyscallRule{"fcntl", Allowance::Always, ArgCheck::FcntlCommands,
                "blocking mode, close-on-exec, memfd seals; nothing that aims a signal (owner, SIGIO, leases)"},
    SyscallRule{"lseek", Allowance::Always, ArgCheck::None, "sizes of memfds the service made"},
    SyscallRule{"fstat", Allowance::Always, ArgCheck::None, "stdio asks what fds 1-2 are"},
    SyscallRule{"newfstatat", Allowance::Always, ArgCheck::EmptyPathStat,
                "fstat() of an fd (AT_EMPTY_PATH); a path only while booting (the loader)"},
    SyscallRule{"pread64", Allowance::Always, ArgCheck::None, "a restored copy reads its pages from a memfd"},
    SyscallRule{"pwrite64", Allowance::Always, ArgCheck::None, "the written pages into a memfd"},
    SyscallRule{"preadv", Allowance::Always, ArgCheck::None, "as pread64, page by page"},
    SyscallRule{"pwritev", Allowance::Always, ArgCheck::None, "as pwrite64, page by page"},
    // ---- memory (never executable once booted: W^X) ----
    SyscallRule{"mmap", Allowance::Always, ArgCheck::ExecOnlyBooting, "heap, thread stacks, the time page"},
    SyscallRule{"mprotect", Allowance::Always, ArgCheck::ExecOnlyBooting, "guard pages, RELRO"},
    SyscallRule{"munmap", Allowance::Always, ArgCheck::None, "the allocator returns memory"},
    SyscallRule{"mremap", Allowance::Always, ArgCheck::None, "the allocator grows a mapping"},
    SyscallRule{"madvise", Allowance::Always, ArgCheck::None, "the allocator returns pages"},
    SyscallRule{"brk", Allowance::Always, ArgCheck::None, "the heap (images restore its end)"},
    // ---- images (docs/design.md §7) ----
    SyscallRule{"clone", Allowance::Always, ArgCheck::CloneFlags,
                "an image is forked as the kernel's child (CLONE_PARENT|SIGCHLD); registered worker threads. "
                "No other process can be made: every process of a service is the kernel's child"},
    SyscallRule{"clone3", Allowance::Enosys, ArgCheck::None,
                "its flags are in memory, out of seccomp's reach: ENOSYS makes the C library use clone"},
    SyscallRule{"memfd_create", Allowance::Always, ArgCheck::None, "the pages of an image by written pages"},
    SyscallRule{"ftruncate", Allowance::Always, ArgCheck::None, "sizing that memfd"},
    SyscallRule{"fallocate", Allowance::Always, ArgCheck::None, "allocating that memfd ahead"},
    SyscallRule{"userfaultfd", Allowance::Always, ArgCheck::None, "tracking the pages written since an image"},
    SyscallRule{"ioctl", Allowance::Always, ArgCheck::IoctlCodes,
                "userfaultfd and PAGEMAP_SCAN requests; TCGETS (isatty). Nothing else: no TIOCSTI"},
    // ---- threads, signals to itself, time, identity ----
    SyscallRule{"futex", Allowance::Always, ArgCheck::None, "locks, condition variables, joining workers"},
    SyscallRule{"set_robust_list", Allowance::Always, ArgCheck::None, "a new thread's robust futex list"},
    SyscallRule{"rseq", Allowance::Always, ArgCheck::None, "a new thread registers restartable sequences"},
    SyscallRule{"sched_yield", Allowance::Always, ArgCheck::None, "spinning workers"},
    SyscallRule{"nanosleep", Allowance::Always, ArgCheck::None, "parking workers"},
    SyscallRule{"clock_nanosleep", Allowance::Always, ArgCheck::None, "parking workers"},
    SyscallRule{"clock_gettime", Allowance::Always, ArgCheck::None, "deadlines (when the vDSO cannot answer)"},
    SyscallRule{"gettimeofday", Allowance::Always, ArgCheck::None, "as clock_gettime"},
    SyscallRule{"rt_sigaction", Allowance::Always, ArgCheck::None, "the C library's own handlers"},
    SyscallRule{"rt_sigprocmask", Allowance::Always, ArgCheck::None, "getcontext/setcontext (images), threads"},
    SyscallRule{"rt_sigreturn", Allowance::Always, ArgCheck::None, "returning from a handler"},
    SyscallRule{"sigaltstack", Allowance::Always, ArgCheck::None, "a thread's alternate signal stack"},
    SyscallRule{"kill", Allowance::Always, ArgCheck::SelfPid,
                "raise() and abort(): to itself only (the kernel compares the target with the caller's pid)"},
    SyscallRule{"tgkill", Allowance::Always, ArgCheck::SelfPid, "as kill"},
    SyscallRule{"getpid", Allowance::Always, ArgCheck::None, "its own pid"},
    SyscallRule{"gettid", Allowance::Always, ArgCheck::None, "its own thread id"},
    SyscallRule{"getppid", Allowance::Always, ArgCheck::None, "checking that the kernel is its parent"},
    SyscallRule{"getuid", Allowance::Always, ArgCheck::None, "identity (harmless)"},
    SyscallRule{"geteuid", Allowance::Always, ArgCheck::None, "identity (harmless)"},
    SyscallRule{"getgid", Allowance::Always, ArgCheck::None, "identity (harmless)"},
    SyscallRule{"getegid", Allowance::Always, ArgCheck::None, "identity (harmless)"},
    SyscallRule{"getrandom", Allowance::Always, ArgCheck::None, "the C++ library's random_device, hash seeds"},
    SyscallRule{"sched_getaffinity", Allowance::Always, ArgCheck::None, "hardware_concurrency(); never set"},
    SyscallRule{"getcpu", Allowance::Always, ArgCheck::None, "sched_getcpu() (when the vDSO cannot answer)"},
    SyscallRule{"prctl", Allowance::Always, ArgCheck::PrctlOptions,
                "thread names and the dumpable flag; while booting also PR_SET_DUMPABLE 0 (the SDK's "
                "non-dumpable switch), nothing else"},
    SyscallRule{"restart_syscall", Allowance::Always, ArgCheck::None, "a call interrupted by a stop"},
    SyscallRule{"exit", Allowance::Always, ArgCheck::None, "a thread ends"},
    SyscallRule{"exit_group", Allowance::Always, ArgCheck::None, "the process ends"},
    // ---- exec and start-up: only until the service is ready ----
    SyscallRule{"execve", Allowance::WhileBooting, ArgCheck::SpawnerOnly,
                "the kernel execs the service's binary (let through by the spawner); no exec of the service's own"},
    SyscallRule{"execveat", Allowance::WhileBooting, ArgCheck::SpawnerOnly, "as execve"},
    SyscallRule{"open", Allowance::WhileBooting, ArgCheck::ReadOnlyOpen,
                "the dynamic loader opens libraries; what it may read is bounded by Landlock (sys/landlock.hpp)"},
    SyscallRule{"openat", Allowance::WhileBooting, ArgCheck::ReadOnlyOpen,
                "the loader's libraries; the SDK reads /proc/self/maps once (memory_image::prepare_self); "
                "Landlock bounds what (the libraries, the binary, /proc/self)"},
    SyscallRule{"access", Allowance::WhileBooting, ArgCheck::None, "the loader"},
    SyscallRule{"faccessat", Allowance::WhileBooting, ArgCheck::None, "the loader"},
    SyscallRule{"faccessat2", Allowance::WhileBooting, ArgCheck::None, "the loader"},
    SyscallRule{"stat", Allowance::WhileBooting, ArgCheck::None, "the loader"},
    SyscallRule{"lstat", Allowance::WhileBooting, ArgCheck::None, "the loader"},
    SyscallRule{"statx", Allowance::WhileBooting, ArgCheck::None, "the loader"},
    SyscallRule{"statfs", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
    SyscallRule{"fstatfs", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
    SyscallRule{"readlink", Allowance::WhileBooting, ArgCheck::None, "the SDK reads /proc/self/exe once"},
    SyscallRule{"readlinkat", Allowance::WhileBooting, ArgCheck::None, "as readlink"},
    SyscallRule{"getdents64", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
    SyscallRule{"getcwd", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
    SyscallRule{"arch_prctl", Allowance::WhileBooting, ArgCheck::None, "thread-local storage of the main thread"},
    SyscallRule{"set_tid_address", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
    SyscallRule{"prlimit64", Allowance::WhileBooting, ArgCheck::OwnLimitsRead,
                "the C library reads its stack limit"},
    SyscallRule{"getrlimit", Allowance::WhileBooting, ArgCheck::None, "as prlimit64 (reading only)"},
    SyscallRule{"uname", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
    SyscallRule{"sysinfo", Allowance::WhileBooting, ArgCheck::None, "the C library's start-up"},
};

// What a network-facing service calls beyond the service list (network_syscalls; docs/sandbox.md "The link"): the
// calls Cyclone DDS makes for its UDP sockets and to list the interfaces (getifaddrs: a netlink socket). Sending and receiving are the service list's
// (sendto, sendmsg, recvfrom, recvmsg); a socket of any other family (AF_UNIX, AF_PACKET, AF_INET6) is refused.
constexpr std::array kNetworkRules{
    SyscallRule{"socket", Allowance::Always, ArgCheck::SocketDomains,
                "Cyclone's UDP sockets (AF_INET) and getifaddrs' interface list (AF_NETLINK); no other family"},
    SyscallRule{"bind", Allowance::Always, ArgCheck::None, "its discovery and data ports; the netlink socket"},
    SyscallRule{"setsockopt", Allowance::Always, ArgCheck::None, "buffer sizes, address reuse, TTL of its sockets"},
    SyscallRule{"getsockopt", Allowance::Always, ArgCheck::None, "the buffer sizes it got"},
    SyscallRule{"getsockname", Allowance::Always, ArgCheck::None, "the port a socket was bound to"},
    SyscallRule{"select", Allowance::Always, ArgCheck::None, "Cyclone's receive thread waits on its sockets"},
    SyscallRule{"pselect6", Allowance::Always, ArgCheck::None, "as select"},
    SyscallRule{"pipe2", Allowance::Always, ArgCheck::None, "Cyclone wakes its receive thread through a pipe"},
    SyscallRule{"uname", Allowance::Always, ArgCheck::None,
                "the host name Cyclone announces in its participant's discovery data, asked again at run time"},
    SyscallRule{"ioctl", Allowance::Always, ArgCheck::NetworkIoctlCodes,
                "SIOCGIFINDEX: an interface's index (if_nametoindex), beside the service list's codes"},
};
// The ioctl request codes of a network-facing service beyond the service list's (kIoctlCodes).
constexpr std::array<unsigned long, 1> kNetworkIoctlCodes{SIOCGIFINDEX};

// What the sanitizer's runtime in a service calls by itself, admitted only in a sanitizer build
// (REJUV_SANITIZER: kernel_sim/sys/CMakeLists.txt sets it when CMAKE_CXX_FLAGS has -fsanitize=, as the asan
// and tsan presets do). A release build's filter has none of these; docs/sandbox.md lists them apart.
#if defined(REJUV_SANITIZER)
constexpr std::array kSanitizerRules{
    SyscallRule{"pipe2", Allowance::Always, ArgCheck::None,
                "sanitizer build: UBSan's vptr check asks whether memory is readable by writing it into a "
                "pipe it makes and closes at once (IsAccessibleMemoryRange)"},
    SyscallRule{"unlink", Allowance::WhileBooting, ArgCheck::None,
                "sanitizer build: ThreadSanitizer's start-up backs its read-only shadow with a file it makes in "
                "TMPDIR and unlinks at once (MapRodata); a service's read-only mounts make the open fail first"},
    SyscallRule{"unlinkat", Allowance::WhileBooting, ArgCheck::None,
                "sanitizer build: as unlink (Clang's ThreadSanitizer runtime calls this one)"},
};
#else
constexpr std::array<SyscallRule, 0> kSanitizerRules{};
#endif

template <std::size_t A, std::size_t B>
constexpr std::array<SyscallRule, A + B> joined(const std::array<SyscallRule, A>& a,
                                                const std::array<SyscallRule, B>& b) {
  std::array<SyscallRule, A + B> out{};
  std::copy(a.begin(), a.end(), out.begin());
  std::copy(b.begin(), b.end(), out.begin() + A);
  return out;
}
constexpr auto kRules = joined(kServiceRules, kSanitizerRules);

struct CtxDeleter {
  void operator()(void* ctx) const { seccomp_release(ctx); }
};

// The rules libseccomp gets for one entry under `enforcement`. `allow` is ALLOW; calls that fail an argument
// check fall through to the default action (the supervisor, or death).
int add_rule(scmp_filter_ctx ctx, const SyscallRule& rule, int nr, Enforcement enforcement) {
  const std::uint32_t allow = SCMP_ACT_ALLOW;
  if (rule.allowance == Allowance::Enosys) return seccomp_rule_add(ctx, SCMP_ACT_ERRNO(ENOSYS), nr, 0);
  if (rule.allowance == Allowance::WhileBooting) {
    // Supervised: the default action already sends it to the kernel. Standalone: allowed.
    return enforcement == Enforcement::Standalone ? seccomp_rule_add(ctx, allow, nr, 0) : 0;
  }
  int rc = 0;
  switch (rule.check) {
    case ArgCheck::None: return seccomp_rule_add(ctx, allow, nr, 0);
    case ArgCheck::SelfPid:
      // Supervised: the kernel compares the target with the caller's pid (a restored image has another pid
      // than the process the filter was installed in). Standalone: the installing process's pid.
      if (enforcement == Enforcement::Supervised) return 0;
      return seccomp_rule_add(ctx, allow, nr, 1, SCMP_A0(SCMP_CMP_EQ, kSelfPidSentinel));
    case ArgCheck::CloneFlags:
      rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A0(SCMP_CMP_EQ, kImageForkFlags));
      rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A0(SCMP_CMP_EQ, kThreadFlags));
      return rc;
    case ArgCheck::ExecOnlyBooting:
      if (enforcement == Enforcement::Standalone) return seccomp_rule_add(ctx, allow, nr, 0);
      return seccomp_rule_add(ctx, allow, nr, 1, SCMP_A2(SCMP_CMP_MASKED_EQ, PROT_EXEC, 0));
    case ArgCheck::IoctlCodes:
      for (const unsigned long code : kIoctlCodes) {
        rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A1(SCMP_CMP_EQ, static_cast<scmp_datum_t>(code)));
      }
      return rc;
    case ArgCheck::PrctlOptions:
      if (enforcement == Enforcement::Standalone) return seccomp_rule_add(ctx, allow, nr, 0);
      for (const int option : kPrctlOptions) {
        rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A0(SCMP_CMP_EQ, static_cast<scmp_datum_t>(option)));
      }
      return rc;
    case ArgCheck::EmptyPathStat:
      if (enforcement == Enforcement::Standalone) return seccomp_rule_add(ctx, allow, nr, 0);
      return seccomp_rule_add(ctx, allow, nr, 1, SCMP_A3(SCMP_CMP_MASKED_EQ, AT_EMPTY_PATH, AT_EMPTY_PATH));
    case ArgCheck::FcntlCommands:
      for (const int command : kFcntlCommands) {
        rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A1(SCMP_CMP_EQ, static_cast<scmp_datum_t>(command)));
      }
      // The flags are a register value: O_ASYNC can be checked here, unlike a path or a struct.
      rc |= seccomp_rule_add(ctx, allow, nr, 2, SCMP_A1(SCMP_CMP_EQ, static_cast<scmp_datum_t>(F_SETFL)),
                             SCMP_A2(SCMP_CMP_MASKED_EQ, static_cast<scmp_datum_t>(O_ASYNC), 0));
      return rc;
    case ArgCheck::SocketDomains:
      for (const int domain : {AF_INET, AF_NETLINK}) {
        rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A0(SCMP_CMP_EQ, static_cast<scmp_datum_t>(domain)));
      }
      // The C library asks for an AF_UNIX socket first where any family will do (if_nametoindex's __opensock)
      // and falls back to AF_INET when the family is not supported: refused so, not counted as a violation.
      rc |= seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EAFNOSUPPORT), nr, 1,
                             SCMP_A0(SCMP_CMP_EQ, static_cast<scmp_datum_t>(AF_UNIX)));
      return rc;
    case ArgCheck::NetworkIoctlCodes:
      for (const unsigned long code : kNetworkIoctlCodes) {
        rc |= seccomp_rule_add(ctx, allow, nr, 1, SCMP_A1(SCMP_CMP_EQ, static_cast<scmp_datum_t>(code)));
      }
      return rc;
    case ArgCheck::ReadOnlyOpen:
    case ArgCheck::OwnLimitsRead:
    case ArgCheck::SpawnerOnly: return -EINVAL;  // boot calls' checks: the kernel's (classify), never an Always entry
  }
  return -EINVAL;
}

// The open flags a boot may use: reading (O_RDONLY, with any of these); everything else — O_WRONLY, O_RDWR,
// O_CREAT, O_TRUNC, O_APPEND, O_TMPFILE — writes or makes something, which no loader or start-up needs.
constexpr std::uint64_t kReadOnlyOpenFlags = O_RDONLY | O_CLOEXEC | O_DIRECTORY | O_NOFOLLOW | O_NONBLOCK |
                                             O_NOCTTY | O_LARGEFILE | O_NOATIME | O_PATH;

// Whether a WhileBooting call's register arguments are what a start-up needs (ArgCheck of the boot calls).
bool boot_arguments_pass(const SyscallRule& rule, const SeccompNotice& notice) {
  if (rule.check == ArgCheck::ReadOnlyOpen) {
    const std::uint64_t flags = rule.name == "open" ? notice.args[1] : notice.args[2];
    return (flags & ~kReadOnlyOpenFlags) == 0;
  }
  if (rule.check == ArgCheck::OwnLimitsRead) {
    // pid_t is 32 bits; the new limit is a pointer (arg 2) that must be NULL: reading only.
    const auto pid = static_cast<std::int32_t>(static_cast<std::uint32_t>(notice.args[0]));
    return (pid == 0 || (notice.tgid > 0 && pid == notice.tgid)) && notice.args[2] == 0;
  }
  return rule.check != ArgCheck::SpawnerOnly;
}

// A prctl outside the running service's options (kPrctlOptions) while booting: only the SDK's non-dumpable
// switch (PR_SET_DUMPABLE 0). In a sanitizer build, whatever the runtime asks at start.
bool boot_prctl(const SeccompNotice& notice) {
#if defined(REJUV_SANITIZER)
  (void)notice;
  return true;
#else
  return notice.args[0] == PR_SET_DUMPABLE && notice.args[1] == 0;
#endif
}

const SyscallRule* rule_of(int nr) {
  for (const SyscallRule& r : kRules) {
    if (syscall_number(r.name) == nr) return &r;
  }
  return nullptr;
}

}  // namespace

std::span<const SyscallRule> service_syscalls() { return kRules; }
std::span<const SyscallRule> network_syscalls() { return kNetworkRules; }

std::optional<int> syscall_number(std::string_view name) {
  const std::string n(name);
  const int nr = seccomp_syscall_resolve_name(n.c_str());
  if (nr == __NR_SCMP_ERROR || nr < 0) return std::nullopt;
  return nr;
}

std::string syscall_name(int nr) {
  char* name = seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr);
  if (name == nullptr) return "syscall " + std::to_string(nr);
  std::string out(name);
  std::free(name);  // NOLINT(cppcoreguidelines-no-malloc): libseccomp's allocation
  return out;
}

NoticeKind classify(const SeccompNotice& notice) {
  const SyscallRule* rule = rule_of(notice.nr);
  if (rule == nullptr) return NoticeKind::Forbidden;
  switch (rule->allowance) {
    case Allowance::WhileBooting: return boot_arguments_pass(*rule, notice) ? NoticeKind::BootCall : NoticeKind::RefusedAtBoot;
    case Allowance::Enosys: return NoticeKind::Forbidden;  // never notified
    case Allowance::Always: break;
  }
  // An Always entry whose argument check failed: some fail only after boot.
  switch (rule->check) {
    case ArgCheck::ExecOnlyBooting:
    case ArgCheck::EmptyPathStat: return NoticeKind::BootCall;
    case ArgCheck::PrctlOptions: return boot_prctl(notice) ? NoticeKind::BootCall : NoticeKind::RefusedAtBoot;
    case ArgCheck::SelfPid:  // kill(pid, …), tgkill(tgid, tid, …): the caller's own process
      // The notice names the calling thread; the target is a process (kill) or a thread group (tgkill, which
      // the kernel delivers only to a thread of that group). So the caller's thread group is compared, and a
      // worker thread's raise() is the service signalling itself. pid_t is 32 bits: the upper half of the
      // register is not the caller's to rely on.
      return notice.tgid > 0 && static_cast<std::uint32_t>(notice.args[0]) == static_cast<std::uint32_t>(notice.tgid)
                 ? NoticeKind::SignalToSelf
                 : NoticeKind::Forbidden;
    case ArgCheck::None:
    case ArgCheck::CloneFlags:
    case ArgCheck::IoctlCodes:
    case ArgCheck::FcntlCommands:
    case ArgCheck::ReadOnlyOpen:
    case ArgCheck::OwnLimitsRead:
    case ArgCheck::SpawnerOnly:
    case ArgCheck::SocketDomains:
    case ArgCheck::NetworkIoctlCodes: return NoticeKind::Forbidden;
  }
  return NoticeKind::Forbidden;
}

SysResult<SeccompProgram> SeccompProgram::service_policy(Enforcement enforcement) { return build(enforcement, false); }

SysResult<SeccompProgram> SeccompProgram::network_service_policy(Enforcement enforcement) {
  return build(enforcement, true);
}

SysResult<SeccompProgram> SeccompProgram::build(Enforcement enforcement, bool network) {
  // Supervised: what the table does not allow goes to the kernel, which names it, counts it and kills the
  // process (an EPERM would leave a compromised process running that probes on). Standalone: death by SIGSYS.
  const std::uint32_t deflt = enforcement == Enforcement::Supervised ? SCMP_ACT_NOTIFY : SCMP_ACT_KILL_PROCESS;
  std::unique_ptr<void, CtxDeleter> ctx(seccomp_init(deflt));
  if (!ctx) return std::unexpected(SysError{"seccomp_init", ENOMEM});
  int rc = seccomp_attr_set(ctx.get(), SCMP_FLTATR_ACT_BADARCH, SCMP_ACT_KILL_PROCESS);  // no 32-bit ABI
  rc |= seccomp_attr_set(ctx.get(), SCMP_FLTATR_CTL_OPTIMIZE, 2);  // binary tree: O(log n) per call
  if (rc != 0) return std::unexpected(SysError{"seccomp_attr_set", -rc});
  const std::span<const SyscallRule> network_rules = network ? std::span<const SyscallRule>(kNetworkRules)
                                                               : std::span<const SyscallRule>{};
  for (const std::span<const SyscallRule> rules : {std::span<const SyscallRule>(kRules), network_rules}) {
    for (const SyscallRule& rule : rules) {
      const auto nr = syscall_number(rule.name);
      if (!nr) continue;  // not on this architecture (open/stat on arm64, say)
      if (const int erc = add_rule(ctx.get(), rule, *nr, enforcement); erc != 0) {
        return std::unexpected(SysError{"seccomp_rule_add", -erc});
      }
    }
  }
  // libseccomp 2.5 exports to an fd only: go through a memfd.
  UniqueFd mem(::memfd_create("rejuv-seccomp", MFD_CLOEXEC));
  if (!mem) return last_error("memfd_create");
  if (const int erc = seccomp_export_bpf(ctx.get(), mem.get()); erc != 0) {
    return std::unexpected(SysError{"seccomp_export_bpf", -erc});
  }
  const off_t size = ::lseek(mem.get(), 0, SEEK_END);
  if (size <= 0 || size % static_cast<off_t>(sizeof(sock_filter)) != 0) {
    return std::unexpected(SysError{"seccomp_export_bpf", EINVAL});
  }
  SeccompProgram program;
  program.enforcement_ = enforcement;
  program.filter_.resize(static_cast<std::size_t>(size) / sizeof(sock_filter));
  if (::pread(mem.get(), program.filter_.data(), static_cast<std::size_t>(size), 0) != size) {
    return last_error("pread");
  }
  return program;
}

SysResult<UniqueFd> SeccompProgram::install() const {
  std::vector<sock_filter> copy = filter_;
  int listener = -1;
  if (const int err = install_in_child(copy.data(), ::getpid(), &listener); err != 0) {
    return std::unexpected(SysError{"seccomp(SECCOMP_SET_MODE_FILTER)", err});
  }
  return UniqueFd(listener);
}

int SeccompProgram::install_in_child(sock_filter* scratch, pid_t self, int* listener) const noexcept {
  for (std::size_t i = 0; i < filter_.size(); ++i) {
    scratch[i] = filter_[i];
    if (scratch[i].k == kSelfPidSentinel) scratch[i].k = static_cast<std::uint32_t>(self);
  }
  // No core dump when the process is killed: nothing of a service's memory is written to disk.
  const rlimit no_core{0, 0};
  if (::setrlimit(RLIMIT_CORE, &no_core) != 0) return errno;
  if (::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) return errno;
  sock_fprog prog{static_cast<unsigned short>(filter_.size()), scratch};
  const unsigned flags = enforcement_ == Enforcement::Supervised ? SECCOMP_FILTER_FLAG_NEW_LISTENER : 0U;
  const long rc = ::syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER, flags, &prog);
  if (rc < 0) return errno;
  if (listener != nullptr) *listener = enforcement_ == Enforcement::Supervised ? static_cast<int>(rc) : -1;
  return 0;
}

// ---- the supervisor's side ----

SysResult<std::optional<SeccompNotice>> SeccompListener::receive() const {
  // NOTIF_RECV waits for a notice whatever the fd's flags: ask poll first.
  pollfd p{fd_.get(), POLLIN, 0};
  if (::poll(&p, 1, 0) < 0) return last_error("poll(seccomp listener)");
  if ((p.revents & POLLIN) == 0) return std::optional<SeccompNotice>{};
  seccomp_notif n{};
  if (::ioctl(fd_.get(), SECCOMP_IOCTL_NOTIF_RECV, &n) != 0) {
    if (errno == ENOENT || errno == EINTR) return std::optional<SeccompNotice>{};  // its process died meanwhile
    return last_error("ioctl(SECCOMP_IOCTL_NOTIF_RECV)");
  }
  SeccompNotice out{.id = n.id, .pid = static_cast<pid_t>(n.pid), .tgid = 0, .nr = n.data.nr, .args = {}};
  for (std::size_t i = 0; i < out.args.size(); ++i) out.args[i] = n.data.args[i];
  // The thread's process, read while it waits in the call; valid only if it still waits afterwards (a tid
  // reused meanwhile would belong to another process).
  if (const auto tgid = thread_group_of(out.pid); tgid && still_waiting(out.id)) out.tgid = *tgid;
  return std::optional<SeccompNotice>{out};
}

SysResult<void> SeccompListener::allow(std::uint64_t id) const {
  seccomp_notif_resp r{.id = id, .val = 0, .error = 0, .flags = SECCOMP_USER_NOTIF_FLAG_CONTINUE};
  if (::ioctl(fd_.get(), SECCOMP_IOCTL_NOTIF_SEND, &r) != 0 && errno != ENOENT) {
    return last_error("ioctl(SECCOMP_IOCTL_NOTIF_SEND)");
  }
  return {};
}

SysResult<void> SeccompListener::refuse(std::uint64_t id, int error) const {
  seccomp_notif_resp r{.id = id, .val = 0, .error = -error, .flags = 0};
  if (::ioctl(fd_.get(), SECCOMP_IOCTL_NOTIF_SEND, &r) != 0 && errno != ENOENT) {
    return last_error("ioctl(SECCOMP_IOCTL_NOTIF_SEND)");
  }
  return {};
}

bool SeccompListener::still_waiting(std::uint64_t id) const {
  std::uint64_t copy = id;
  return ::ioctl(fd_.get(), SECCOMP_IOCTL_NOTIF_ID_VALID, &copy) == 0;
}

}  // namespace rejuv::sys
