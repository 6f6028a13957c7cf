// service_fork_probe EXECUTABLE [N]: what start-up and fork() cost in a process of a given service build
// (services with and without protobuf, side by side). Starts EXECUTABLE under ptrace, stops it at `main` (after its
// static initialisation, protobuf's included, before it connects to any kernel), reports its RSS and mappings
// there, then has it make N copies of itself with clone(CLONE_PARENT | SIGCHLD) — the call of sys::fork_sibling,
// which makes every service image — and N getpid() calls the same way. Prints the median and max of each, and
// their difference: the fork itself, without the cost of stepping the tracee. Each copy exits at once.
//
//   build/default/bench/image/service_fork_probe build/default/bin/rejuv_ekf2 200
//
// The executable must be statically linked and not position-independent (a service of the default build):
// `main` is found at its link address with `nm`.
#include <sched.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/syscall.h>
#include <sys/user.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace {

std::uint64_t main_address(const char* exe) {
  const std::string command = std::string("nm ") + exe + " | awk '$2==\"T\" && $3==\"main\"{print $1}'";
  FILE* p = ::popen(command.c_str(), "r");
  if (p == nullptr) return 0;
  char line[64] = {};
  const bool read = std::fgets(line, sizeof line, p) != nullptr;
  ::pclose(p);
  return read ? std::strtoull(line, nullptr, 16) : 0;
}

std::string status_field(pid_t pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key + ":", 0) == 0) return line.substr(key.size() + 1);
  }
  return "?";
}

std::size_t map_count(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/maps");
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

bool wait_stopped(pid_t pid) {
  int status = 0;
  return ::waitpid(pid, &status, 0) == pid && WIFSTOPPED(status);
}

// One system call `nr` with arguments `a0`, `a1` made by the stopped tracee at `at` (where a `syscall`
// instruction is): its duration as seen from here [µs], and its return value.
double step_syscall(pid_t pid, const user_regs_struct& base, std::uint64_t at, long nr, std::uint64_t a0,
                    std::uint64_t a1, long& result) {
  user_regs_struct r = base;
  r.rip = at;
  r.rax = static_cast<std::uint64_t>(nr);
  r.orig_rax = static_cast<std::uint64_t>(-1);
  r.rdi = a0;
  r.rsi = a1;
  r.rdx = r.r10 = r.r8 = 0;
  ::ptrace(PTRACE_SETREGS, pid, nullptr, &r);
  const auto t0 = std::chrono::steady_clock::now();
  ::ptrace(PTRACE_SINGLESTEP, pid, nullptr, nullptr);
  if (!wait_stopped(pid)) return -1;
  const auto t1 = std::chrono::steady_clock::now();
  ::ptrace(PTRACE_GETREGS, pid, nullptr, &r);
  result = static_cast<long>(r.rax);
  return std::chrono::duration<double, std::micro>(t1 - t0).count();
}

struct Stats {
  double median = 0, max = 0;
};
Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return Stats{v[v.size() / 2], v.back()};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: service_fork_probe EXECUTABLE [N]\n");
    return 2;
  }
  const char* exe = argv[1];
  const int n = argc > 2 ? std::atoi(argv[2]) : 200;
  const std::uint64_t main_at = main_address(exe);
  if (main_at == 0 || n < 1) {
    std::fprintf(stderr, "service_fork_probe: no `main` in %s (a static, non-PIE executable?) or bad N\n", exe);
    return 2;
  }
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::ptrace(PTRACE_TRACEME, 0, nullptr, nullptr);
    char* const child_argv[] = {const_cast<char*>(exe), nullptr};
    char* const child_env[] = {nullptr};
    ::execve(exe, child_argv, child_env);
    _exit(127);
  }
  if (!wait_stopped(pid)) return 1;  // stopped at exec
  ::ptrace(PTRACE_SETOPTIONS, pid, nullptr, PTRACE_O_EXITKILL);
  // A breakpoint at main; there, main's first bytes become `syscall` (0f 05) for the probes.
  const long original = ::ptrace(PTRACE_PEEKTEXT, pid, main_at, nullptr);
  ::ptrace(PTRACE_POKETEXT, pid, main_at, (original & ~0xffL) | 0xcc);
  const auto init_start = std::chrono::steady_clock::now();
  ::ptrace(PTRACE_CONT, pid, nullptr, nullptr);
  if (!wait_stopped(pid)) return 1;
  const double init_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - init_start).count();
  // syscall; mov eax, 60; xor edi, edi; syscall — the probe's call, then exit(0) for a copy that resumes there.
  const unsigned char code[] = {0x0f, 0x05, 0xb8, 0x3c, 0x00, 0x00, 0x00, 0x31, 0xff, 0x0f, 0x05};
  for (std::size_t off = 0; off < sizeof code; off += sizeof(long)) {
    long word = ::ptrace(PTRACE_PEEKTEXT, pid, main_at + off, nullptr);
    if (off == 0) word = original;
    std::memcpy(&word, code + off, std::min(sizeof(long), sizeof code - off));
    ::ptrace(PTRACE_POKETEXT, pid, main_at + off, word);
  }
  user_regs_struct base{};
  ::ptrace(PTRACE_GETREGS, pid, nullptr, &base);

  std::printf("%s: exec to main (static initialisation) %.0f us; at main: VmRSS%s, %zu mappings\n", exe, init_us,
              status_field(pid, "VmRSS").c_str(), map_count(pid));
  std::vector<double> fork_us, getpid_us;
  for (int i = 0; i < n; ++i) {
    long r = 0;
    getpid_us.push_back(step_syscall(pid, base, main_at, SYS_getpid, 0, 0, r));
    // The copy resumes after the `syscall` at main + 2 and exits; it is our child (CLONE_PARENT): reaped here.
    fork_us.push_back(step_syscall(pid, base, main_at, SYS_clone, CLONE_PARENT | SIGCHLD, 0, r));
    if (r > 0) ::waitpid(static_cast<pid_t>(r), nullptr, 0);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
  const Stats f = stats(fork_us), g = stats(getpid_us);
  std::printf("  clone(CLONE_PARENT) p50 %.1f us, max %.1f us; getpid p50 %.1f us; fork alone p50 %.1f us (n = %d)\n",
              f.median, f.max, g.median, f.median - g.median, n);
  return 0;
}
