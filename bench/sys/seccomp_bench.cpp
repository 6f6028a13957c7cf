// The allow-list filter's cost per system call (docs/design.md §7 "Protection": the filter is on the hot
// path of every frame a service sends or reads). Side by side in one run: the same calls in a thread without a
// filter (the baseline) and in a thread with the service filter (seccomp filters are per thread unless
// synchronised, so the benchmark process itself stays unfiltered). The filtered thread uses the standalone form
// of the filter, whose rules for the calls measured here are the supervised form's (both allow them in BPF).
//   getppid   the cheapest call: the filter's whole cost shows
//   sendmsg   a 64-byte frame on a SOCK_SEQPACKET pair, the channel's call (and recvmsg on the other end)
#include <benchmark/benchmark.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <functional>
#include <thread>
#include <vector>

#include "rejuv/sys/seccomp.hpp"

namespace rejuv::sys {
namespace {

// Runs `body` in a fresh thread, with the service filter installed in that thread when `filtered`.
void in_thread(bool filtered, const std::function<void()>& body) {
  static const auto program = SeccompProgram::service_policy(Enforcement::Standalone);
  std::thread t([&] {
    if (filtered) {
      std::vector<sock_filter> scratch(program->scratch_size());
      int listener = -1;
      if (program->install_in_child(scratch.data(), static_cast<pid_t>(::getpid()), &listener) != 0) std::abort();
    }
    body();
  });
  t.join();
}

void Getppid(benchmark::State& state) {
  in_thread(state.range(0) != 0, [&] {
    for (auto _ : state) benchmark::DoNotOptimize(::syscall(SYS_getppid));
  });
  state.SetLabel(state.range(0) != 0 ? "with the allow-list" : "no filter (baseline)");
}
BENCHMARK(Getppid)->Arg(0)->Arg(1)->UseRealTime();

void SendmsgRecvmsg(benchmark::State& state) {
  std::array<int, 2> pair{-1, -1};
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, pair.data()) != 0) std::abort();
  in_thread(state.range(0) != 0, [&] {
    std::array<char, 64> frame{};
    for (auto _ : state) {
      iovec iov{frame.data(), frame.size()};
      msghdr msg{};
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      benchmark::DoNotOptimize(::sendmsg(pair[0], &msg, 0));
      benchmark::DoNotOptimize(::recvmsg(pair[1], &msg, 0));
    }
  });
  ::close(pair[0]);
  ::close(pair[1]);
  state.SetLabel(state.range(0) != 0 ? "with the allow-list" : "no filter (baseline)");
}
BENCHMARK(SendmsgRecvmsg)->Arg(0)->Arg(1)->UseRealTime();

}  // namespace
}  // namespace rejuv::sys

BENCHMARK_MAIN();
