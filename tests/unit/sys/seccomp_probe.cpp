// Test helper run as a real child process: tries one forbidden action and reports by exit code.
//   0 = the action was denied with EPERM, 1 = it was allowed, 2 = bad usage or another error.
// Under the service filter a forbidden action never returns: the process dies by SIGSYS (seccomp.hpp).
#include <fcntl.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/socket.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <sched.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include <pthread.h>
#include <sys/resource.h>

#include "rejuv/sys/sanitizer.hpp"

#if defined(REJUV_ASAN)
// As in a service (services/sdk): LeakSanitizer's exit check needs ptrace, which the filter forbids, so a
// probe that exits normally would hang in it.
extern "C" int __lsan_is_turned_off() { return 1; }  // NOLINT(bugprone-reserved-identifier)
#endif

#include "rejuv/sys/seccomp.hpp"

namespace {
int verdict(long rc) {
  if (rc >= 0) return 1;
  return errno == EPERM ? 0 : 2;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  const std::string_view what = argv[1];
  if (what == "socket") return verdict(::socket(AF_INET, SOCK_DGRAM, 0));
  if (what == "unix-socket") return verdict(::socket(AF_UNIX, SOCK_STREAM, 0));
  if (what == "socketpair") {
    int fds[2] = {-1, -1};
    return verdict(::socketpair(AF_UNIX, SOCK_STREAM, 0, fds));
  }
  if (what == "process-vm-readv") {  // read a byte of the parent
    char local_byte = 0;
    char remote_byte = 0;
    iovec local{&local_byte, 1};
    iovec remote{&remote_byte, 1};
    return verdict(::process_vm_readv(::getppid(), &local, 1, &remote, 1, 0));
  }
  if (what == "ptrace") return verdict(::ptrace(PTRACE_TRACEME, 0, nullptr, nullptr));
  if (what == "kill-parent") return verdict(::kill(::getppid(), 0));
  if (what == "kill-self") return verdict(::kill(::getpid(), 0));
  if (what == "exec") return verdict(::execl("/bin/true", "true", nullptr));
  if (what == "fork") return verdict(::fork());  // glibc: clone without CLONE_PARENT
  if (what == "clone-parent") {  // the image fork's flags: allowed, the child is the parent's parent's
    const long pid = ::syscall(SYS_clone, CLONE_PARENT | SIGCHLD, nullptr, nullptr, nullptr, nullptr);
    if (pid == 0) ::_exit(0);
    return verdict(pid);
  }
  if (what == "clone-newuser") {
    const long pid = ::syscall(SYS_clone, CLONE_PARENT | CLONE_NEWUSER | SIGCHLD, nullptr, nullptr, nullptr, nullptr);
    if (pid == 0) ::_exit(0);
    return verdict(pid);
  }
  if (what == "thread") {  // pthread_create: clone3 refused with ENOSYS, then clone with a thread's flags
    pthread_t t{};
    if (pthread_create(&t, nullptr, [](void*) -> void* { return nullptr; }, nullptr) != 0) return 2;
    pthread_join(t, nullptr);
    return 1;
  }
  if (what == "io-uring") return verdict(::syscall(425 /* io_uring_setup */, 1, nullptr));
  if (what == "tiocsti") {
    const char c = 'x';
    return verdict(::ioctl(0, TIOCSTI, &c));
  }
  if (what == "mmap-exec") {
    void* m = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE | PROT_EXEC, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    return verdict(m == MAP_FAILED ? -1 : 0);
  }
  if (what == "setsid") return verdict(::setsid());
  if (what == "fcntl-setown") return verdict(::fcntl(1, F_SETOWN, -::getpgrp()));
  if (what == "fcntl-setsig") return verdict(::fcntl(1, F_SETSIG, SIGKILL));
  if (what == "fcntl-async") return verdict(::fcntl(1, F_SETFL, ::fcntl(1, F_GETFL) | O_ASYNC));
  if (what == "fcntl-nonblock") return verdict(::fcntl(1, F_SETFL, ::fcntl(1, F_GETFL) | O_NONBLOCK));
  if (what == "unshare-net") return verdict(::unshare(CLONE_NEWNET));
  if (what == "affinity") {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(0, &set);
    return verdict(::sched_setaffinity(0, sizeof(set), &set));
  }
  if (what == "open-after-ready") {  // boot calls first (the loader, this open), then "ready" on fd 1, then open
    const int fd = ::open("/etc/hostname", O_RDONLY);
    if (fd >= 0) ::close(fd);
    if (::write(1, "ready\n", 6) != 6) return 2;
    char c = 0;
    if (::read(0, &c, 1) != 1) return 2;  // the supervisor says it has seen "ready"
    return verdict(::open("/etc/passwd", O_RDONLY));
  }
  if (what == "write-file") {  // a file in /tmp: refused by the read-only mounts of the sandbox's namespaces
    const int fd = ::open(argc > 2 ? argv[2] : "/tmp/rejuv-probe-file", O_WRONLY | O_CREAT | O_EXCL, 0600);
    if (fd < 0) return errno == EROFS ? 0 : 2;
    ::close(fd);
    return 1;
  }
  if (what == "rlimit-files") {  // exit code: RLIMIT_NOFILE's soft limit, capped at 250
    rlimit r{};
    if (::getrlimit(RLIMIT_NOFILE, &r) != 0) return 255;
    return r.rlim_cur > 250 ? 250 : static_cast<int>(r.rlim_cur);
  }
  if (what == "fd3") {  // prints what arrives on fd 3 (fd layout check)
    char buf[64] = {};
    const ssize_t n = ::read(3, buf, sizeof(buf) - 1);
    if (n <= 0) return 2;
    return std::string_view(buf, static_cast<std::size_t>(n)) == "hello" ? 0 : 1;
  }
  if (what == "fd-count") {  // exit code = number of open fds above stderr
    int count = 0;
    for (int fd = 3; fd < 1024; ++fd) count += ::fcntl(fd, F_GETFD) >= 0 ? 1 : 0;
    return count;
  }
  if (what == "sleep") {
    ::pause();
    return 0;
  }
  return 2;
}
