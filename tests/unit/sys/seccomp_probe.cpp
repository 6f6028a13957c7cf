// Test helper run as a real child process: tries one forbidden action and reports by exit code.
//   0 = the action was denied with EPERM, 1 = it was allowed, 2 = bad usage or another error.
// Under the service filter a forbidden action never returns: the process dies by SIGSYS (seccomp.hpp).
#include <fcntl.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#if defined(__SANITIZE_ADDRESS__)
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
  if (what == "exec-after-sdk") {  // the SDK's second stage: exec is banned after it
    auto program = rejuv::sys::SeccompProgram::service_policy(rejuv::sys::SeccompStage::AfterExec);
    if (!program || !program->install()) return 2;
    return verdict(::execl("/bin/true", "true", nullptr));
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
