// What closing a link costs on the kernel's path at MC → RB (sys::LinkClosure, docs/across_hosts.md "Closing the
// link"), and what the alternative would: one close and one open per iteration of
//   Netlink   LinkClosure::close() + open(): a NEWCHAIN per chain, the policy only, in one nftables transaction
//             over the closure's own netlink socket (what the kernel does)
//   NftExec   the same two policy changes as two fork+exec of `nft` (a table of its own, made by nft)
// in a network namespace of its own with one veth pair (two chains per device: ingress and egress). Root only;
// without root it says so and measures nothing. docs/performance.md "Closing the link" has the numbers.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <sched.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "rejuv/sys/link_closure.hpp"

namespace rejuv::sys {
namespace {

const std::string kNs = "rjN_bench_" + std::to_string(::getpid());
const std::string kDev = "rjNb" + std::to_string(::getpid());

// The namespace, made once, with this thread in it (so that `nft` children start in it too); removed at exit.
bool enter_bench_namespace() {
  static const bool entered = [] {
    if (::geteuid() != 0) return false;
    const std::string ip = "/usr/sbin/ip ";
    if (std::system((ip + "netns add " + kNs).c_str()) != 0) return false;
    std::atexit([] { (void)std::system(("/usr/sbin/ip netns delete " + kNs).c_str()); });
    if (std::system((ip + "-n " + kNs + " link add " + kDev + " type veth peer name " + kDev + "p").c_str()) != 0 ||
        std::system((ip + "-n " + kNs + " link set " + kDev + " up").c_str()) != 0) {
      return false;
    }
    const int fd = ::open(("/run/netns/" + kNs).c_str(), O_RDONLY | O_CLOEXEC);
    const bool ok = fd >= 0 && ::setns(fd, CLONE_NEWNET) == 0;
    if (fd >= 0) ::close(fd);
    return ok;
  }();
  return entered;
}

void Netlink(benchmark::State& state) {
  if (!enter_bench_namespace()) {
    state.SkipWithError("needs root (a network namespace and nftables)");
    return;
  }
  auto link = LinkClosure::create(UplinkSpec{.label = "bench", .netns = std::nullopt, .devices = {kDev}});
  if (!link) {
    state.SkipWithError(link.error().to_string().c_str());
    return;
  }
  for (auto _ : state) {
    if (!link->close() || !link->open()) state.SkipWithError("close/open failed");
  }
}
BENCHMARK(Netlink)->Unit(benchmark::kMicrosecond);

int nft(const std::string& commands) {
  const char* argv[] = {"nft", commands.c_str(), nullptr};
  pid_t pid = -1;
  if (::posix_spawn(&pid, "/usr/sbin/nft", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return -1;
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

void NftExec(benchmark::State& state) {
  if (!enter_bench_namespace()) {
    state.SkipWithError("needs root (a network namespace and nftables)");
    return;
  }
  const std::string chains = "add table netdev rjN_cli; add chain netdev rjN_cli in { type filter hook ingress device " +
                             kDev + " priority 0; policy accept; }; add chain netdev rjN_cli out { type filter hook "
                             "egress device " + kDev + " priority 0; policy accept; }";
  if (nft(chains) != 0) {
    state.SkipWithError("nft could not make its table");
    return;
  }
  for (auto _ : state) {
    if (nft("add chain netdev rjN_cli in { policy drop; }; add chain netdev rjN_cli out { policy drop; }") != 0 ||
        nft("add chain netdev rjN_cli in { policy accept; }; add chain netdev rjN_cli out { policy accept; }") != 0) {
      state.SkipWithError("nft failed");
    }
  }
  (void)nft("delete table netdev rjN_cli");
}
BENCHMARK(NftExec)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rejuv::sys
BENCHMARK_MAIN();
