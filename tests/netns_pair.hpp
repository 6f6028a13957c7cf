// Two network namespaces joined by a veth pair, standing for two hosts (the vehicle's and the companion's) in the
// tests that need root (docs/across_hosts.md): namespaces <prefix>_v<pid> and <prefix>_c<pid>, veth ends
// <prefix>v<pid> in the first and <prefix>c<pid> in the second (a veth name has at most 15 characters: a prefix
// of at most 5), each end given its address when one is asked for, both ends and both loopbacks up. The
// namespaces (and with them the veth pair and any nftables table in them) are deleted when the pair is
// destroyed, also when the making failed half-way. Namespaces of the same prefix left by a run that was killed
// before its clean-up (the pid in their name no longer exists) are deleted before the new ones are made.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "rejuv_cli.hpp"

namespace rejuv::test_support {

class NetnsPair {
 public:
  // `cmd_dir`: an existing folder for the output of the `ip` commands; it must outlive the pair.
  NetnsPair(std::filesystem::path cmd_dir, const std::string& prefix)
      : cmd_dir_(std::move(cmd_dir)),
        prefix_(prefix),
        vehicle(prefix + "_v" + std::to_string(::getpid())),
        companion(prefix + "_c" + std::to_string(::getpid())),
        vehicle_veth(prefix + "v" + std::to_string(::getpid())),
        companion_veth(prefix + "c" + std::to_string(::getpid())) {}
  NetnsPair(const NetnsPair&) = delete;
  NetnsPair& operator=(const NetnsPair&) = delete;
  ~NetnsPair() {
    if (!made_) return;
    for (const std::string& ns : {vehicle, companion}) (void)ip({"netns", "delete", ns});
  }

  // Makes the namespaces and the pair; empty addresses are left unassigned. Empty on success, else the failing
  // `ip` command and what it said.
  [[nodiscard]] std::string make(const std::string& vehicle_address, const std::string& companion_address) {
    remove_stale();
    made_ = true;
    std::vector<std::vector<std::string>> cmds{
        {"netns", "add", vehicle},
        {"netns", "add", companion},
        {"link", "add", vehicle_veth, "type", "veth", "peer", "name", companion_veth},
        {"link", "set", vehicle_veth, "netns", vehicle},
        {"link", "set", companion_veth, "netns", companion}};
    if (!vehicle_address.empty()) cmds.push_back({"-n", vehicle, "addr", "add", vehicle_address + "/24", "dev", vehicle_veth});
    if (!companion_address.empty()) {
      cmds.push_back({"-n", companion, "addr", "add", companion_address + "/24", "dev", companion_veth});
    }
    for (const std::vector<std::string>& up :
         {std::vector<std::string>{"-n", vehicle, "link", "set", vehicle_veth, "up"},
          {"-n", companion, "link", "set", companion_veth, "up"},
          {"-n", vehicle, "link", "set", "lo", "up"},
          {"-n", companion, "link", "set", "lo", "up"}}) {
      cmds.push_back(up);
    }
    for (const std::vector<std::string>& cmd : cmds) {
      const CliOutcome r = ip(cmd);
      if (r.exit_code != 0) return "ip " + cmd[0] + " " + cmd[1] + " " + cmd[2] + " ...: " + r.err;
    }
    return {};
  }

 private:
  CliOutcome ip(std::vector<std::string> args) const {
    return run_program(cmd_dir_, "/usr/sbin/ip", std::move(args));
  }
  // <prefix>_v<pid>, <prefix>_c<pid> of a process that no longer exists.
  void remove_stale() const {
    std::istringstream lines(ip({"netns", "list"}).out);
    const std::size_t n = prefix_.size() + 2;
    for (std::string line; std::getline(lines, line);) {
      const std::string ns = line.substr(0, line.find(' '));
      if (ns.size() <= n || (ns.rfind(prefix_ + "_v", 0) != 0 && ns.rfind(prefix_ + "_c", 0) != 0)) continue;
      const std::string pid = ns.substr(n);
      if (pid.find_first_not_of("0123456789") != std::string::npos || std::filesystem::exists("/proc/" + pid)) continue;
      (void)ip({"netns", "delete", ns});
    }
  }

  std::filesystem::path cmd_dir_;
  std::string prefix_;
  bool made_ = false;

 public:
  const std::string vehicle, companion, vehicle_veth, companion_veth;
};

}  // namespace rejuv::test_support
