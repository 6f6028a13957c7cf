// A cgroup v2 group of a test's own (root): made under the test process's own group in the unified hierarchy
// (/sys/fs/cgroup/unified here), removed by the caller once its processes are gone.
#pragma once

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>

namespace rejuv::test_support {

// The group `name` made under this process's own v2 group; nullopt (and `why`) when there is no v2 hierarchy or
// the group cannot be made.
inline std::optional<std::filesystem::path> make_own_cgroup_v2_group(const std::string& name, std::string& why) {
  std::ifstream in("/proc/self/cgroup");
  std::string own;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("0::", 0) == 0) own = line.substr(3);
  }
  if (own.empty() || !std::filesystem::exists("/sys/fs/cgroup/unified/cgroup.procs")) {
    why = "no cgroup v2 hierarchy";
    return std::nullopt;
  }
  const std::filesystem::path group = std::filesystem::path("/sys/fs/cgroup/unified" + own) / name;
  std::error_code ec;
  std::filesystem::create_directory(group, ec);
  if (ec) {
    why = group.string() + ": " + ec.message();
    return std::nullopt;
  }
  return group;
}

}  // namespace rejuv::test_support
