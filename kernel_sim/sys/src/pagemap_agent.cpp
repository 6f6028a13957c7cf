// The pagemap agent (pagemap_agent.hpp): forked from the kernel, it runs only raw system calls (the kernel
// has threads: a forked child may not touch locks or the heap).
#include "rejuv/sys/pagemap_agent.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>

#include "raw_send.hpp"
#include "rejuv/sys/event.hpp"

namespace rejuv::sys {

namespace {

// "/proc/<pid>/pagemap" into `out` without the heap.
void pagemap_path(pid_t pid, std::array<char, 40>& out) {
  std::array<char, 12> digits{};
  std::size_t n = 0;
  auto v = static_cast<std::uint32_t>(pid);
  do {
    digits[n++] = static_cast<char>('0' + v % 10);  // NOLINT: at most 10 digits
    v /= 10;
  } while (v != 0 && n < digits.size());
  std::size_t at = 0;
  for (const char c : std::string_view("/proc/")) out[at++] = c;  // NOLINT: 40 bytes hold it all
  while (n > 0) out[at++] = digits[--n];                          // NOLINT
  for (const char c : std::string_view("/pagemap")) out[at++] = c;  // NOLINT
  out[at] = '\0';                                                   // NOLINT
}

// Answers one request: the errno (0 on success) and, on success, the fd.
void answer(int sock, int fd, int err) {
  const std::int32_t code = err;
  detail::send_raw_with_fd(sock, &code, sizeof(code), fd);
}

[[noreturn]] void agent_main(int sock, int userns, pid_t parent) {
  // It dies with the kernel, keeps nothing of the kernel's but its socket and the namespace's fd, and enters
  // the namespace (the kernel's uid owns it: every capability inside, none outside).
  if (::prctl(PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0) != 0 || ::getppid() != parent) ::_exit(1);
  const int s = ::fcntl(sock, F_DUPFD_CLOEXEC, 3);
  const int n = ::fcntl(userns, F_DUPFD_CLOEXEC, 4);
  if (s != 3 && ::dup3(s, 3, O_CLOEXEC) != 3) ::_exit(1);
  if (n != 4 && ::dup3(n, 4, O_CLOEXEC) != 4) ::_exit(1);
  if (::syscall(SYS_close_range, 5U, ~0U, 0U) != 0) ::_exit(1);
  for (int fd = 0; fd < 3; ++fd) (void)::close(fd);
  if (::setns(4, CLONE_NEWUSER) != 0) ::_exit(2);
  (void)::close(4);
  for (;;) {
    std::int32_t pid = 0;
    const ssize_t got = ::recv(3, &pid, sizeof(pid), 0);
    if (got == 0) ::_exit(0);  // the kernel closed its end
    if (got != static_cast<ssize_t>(sizeof(pid)) || pid <= 0) {
      if (got < 0 && errno == EINTR) continue;
      answer(3, -1, EINVAL);
      continue;
    }
    std::array<char, 40> path{};
    pagemap_path(static_cast<pid_t>(pid), path);
    const int fd = ::open(path.data(), O_RDONLY | O_CLOEXEC);
    answer(3, fd, fd < 0 ? errno : 0);
    if (fd >= 0) (void)::close(fd);
  }
}

// The inode of a process's user namespace.
SysResult<std::uint64_t> namespace_of(pid_t pid) {
  const std::string path = "/proc/" + std::to_string(pid) + "/ns/user";
  struct stat st{};
  if (::stat(path.c_str(), &st) != 0) return last_error("stat(/proc/PID/ns/user)");
  return static_cast<std::uint64_t>(st.st_ino);
}

}  // namespace

bool PagemapAgent::serves(pid_t member) const {
  const auto ns = namespace_of(member);
  return valid() && ns && *ns == namespace_;
}

SysResult<PagemapAgent> PagemapAgent::start(pid_t member) {
  const std::string ns_path = "/proc/" + std::to_string(member) + "/ns/user";
  UniqueFd userns(::open(ns_path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!userns) return last_error("open(/proc/PID/ns/user)");
  struct stat st{};
  if (::fstat(userns.get(), &st) != 0) return last_error("fstat(/proc/PID/ns/user)");
  auto pair = SeqPacket::pair(Blocking::Yes);
  if (!pair) return std::unexpected(pair.error());
  auto& [mine, theirs] = *pair;
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) return last_error("fork(pagemap agent)");
  if (pid == 0) agent_main(theirs.fd(), userns.get(), parent);
  auto child = ChildProcess::adopt(pid);
  if (!child) {
    (void)kill_and_reap_own_child(pid);
    return std::unexpected(child.error());
  }
  return PagemapAgent(std::move(mine), std::move(*child), static_cast<std::uint64_t>(st.st_ino));
}

SysResult<UniqueFd> PagemapAgent::open_pagemap(pid_t pid) const {
  if (!socket_.valid()) return std::unexpected(SysError{"pagemap agent", EBADF});
  const std::int32_t request = pid;
  if (auto sent = socket_.send(std::as_bytes(std::span(&request, 1))); !sent) return std::unexpected(sent.error());
  auto ready = wait_fd(socket_.fd(), WaitFor::Readable, std::chrono::seconds(1));
  if (!ready) return std::unexpected(ready.error());
  if (!*ready) return std::unexpected(SysError{"pagemap agent: no answer", ETIMEDOUT});
  std::int32_t code = 0;
  auto got = socket_.receive(std::as_writable_bytes(std::span(&code, 1)), 1);
  if (!got) return std::unexpected(got.error());
  if (got->closed) return std::unexpected(SysError{"pagemap agent: gone", EPIPE});
  if (got->size != sizeof(code)) return std::unexpected(SysError{"pagemap agent: answer", EPROTO});
  if (code != 0) return std::unexpected(SysError{"open(/proc/PID/pagemap) in the service's namespace", code});
  if (got->fds.size() != 1) return std::unexpected(SysError{"pagemap agent: no fd", EPROTO});
  return std::move(got->fds.front());
}

}  // namespace rejuv::sys
