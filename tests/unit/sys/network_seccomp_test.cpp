// The network allow-list of the link between hosts (seccomp.hpp network_service_policy; docs/sandbox.md "The
// link"), by its effect in a child process that loads the filter (Standalone: a call outside the list kills it
// with SIGSYS): it may make AF_INET and AF_NETLINK sockets, an AF_UNIX one is refused with EAFNOSUPPORT (the C
// library then falls back to AF_INET), any other family kills it; the service filter every other service gets
// allows no socket at all.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <fstream>
#include <sstream>
#include <string>

#include "rejuv/sys/seccomp.hpp"

namespace rejuv::sys {
namespace {

constexpr int kMade = 0, kNotSupported = 3, kOtherError = 4;

// Exit code of a child that loads the filter and makes one socket; -signal when it was killed.
int socket_under(bool network, int family, int type) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    auto program = network ? SeccompProgram::network_service_policy(Enforcement::Standalone)
                           : SeccompProgram::service_policy(Enforcement::Standalone);
    if (!program) ::_exit(10);
    if (!program->install()) ::_exit(11);
    const int fd = ::socket(family, type, 0);
    if (fd >= 0) ::_exit(kMade);
    ::_exit(errno == EAFNOSUPPORT ? kNotSupported : kOtherError);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFSIGNALED(status) ? -WTERMSIG(status) : WEXITSTATUS(status);
}

TEST(NetworkSeccomp, LinkMakesUdpAndNetlinkSockets) {
  EXPECT_EQ(socket_under(true, AF_INET, SOCK_DGRAM), kMade);
  EXPECT_EQ(socket_under(true, AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC), kMade);
}

TEST(NetworkSeccomp, LinkUnixSocket_RefusedNotSupported) {
  EXPECT_EQ(socket_under(true, AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC), kNotSupported);
}

TEST(NetworkSeccomp, LinkOtherFamilies_Killed) {
  EXPECT_EQ(socket_under(true, AF_PACKET, SOCK_RAW), -SIGSYS);
  EXPECT_EQ(socket_under(true, AF_INET6, SOCK_DGRAM), -SIGSYS);
}

TEST(NetworkSeccomp, ServiceFilter_NoSocketAtAll) {
  EXPECT_EQ(socket_under(false, AF_INET, SOCK_DGRAM), -SIGSYS);
  EXPECT_EQ(socket_under(false, AF_NETLINK, SOCK_RAW), -SIGSYS);
}

TEST(NetworkSeccomp, NetworkListIsItsOwn) {
  // The extra calls are listed apart (docs/sandbox.md prints both), and none is in the service list.
  for (const SyscallRule& n : network_syscalls()) {
    if (n.name == "ioctl") continue;  // more request codes for a call the service list has
    if (n.name == "uname") continue;  // a boot call for services, at any time for a link
    for (const SyscallRule& s : service_syscalls()) EXPECT_NE(n.name, s.name) << n.name;
  }
}

TEST(NetworkSeccomp, DocsSandboxListsEveryEntry) {
  std::ifstream doc(std::string(REJUV_SOURCE_DIR) + "/docs/sandbox.md");
  ASSERT_TRUE(doc.good());
  std::stringstream buffer;
  buffer << doc.rdbuf();
  const std::string text = buffer.str();
  const std::size_t section = text.find("## The link between hosts: a network-facing service");
  ASSERT_NE(section, std::string::npos);
  for (const SyscallRule& r : network_syscalls()) {
    EXPECT_NE(text.find("| `" + std::string(r.name) + "` | always |", section), std::string::npos)
        << "docs/sandbox.md \"The link between hosts\" does not list " << r.name;
  }
}

}  // namespace
}  // namespace rejuv::sys
