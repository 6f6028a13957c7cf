// `rejuv run GRAPH --host NAME` (docs/across_hosts.md "One kernel per host"): the part of a graph across hosts that
// runs on host NAME under its own kernel — NAME's services and its links to the peer hosts (policy/hosts.hpp
// add_host_links), the plant only on the vehicle's host, SR only where the rejuvenation service is (the `hosts`
// audit keeps it on the vehicle's host).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {

// A directory of this process's own under the temporary folder, removed with what it holds when dropped.
class RunTempDir {
 public:
  [[nodiscard]] static Result<RunTempDir, std::string> create(std::string_view prefix);
  RunTempDir(RunTempDir&& other) noexcept : path_(std::exchange(other.path_, {})) {}
  RunTempDir& operator=(RunTempDir&& other) noexcept;
  RunTempDir(const RunTempDir&) = delete;
  RunTempDir& operator=(const RunTempDir&) = delete;
  ~RunTempDir();
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  explicit RunTempDir(std::filesystem::path path) : path_(std::move(path)) {}
  std::filesystem::path path_;
};

struct HostPart {
  std::string host;
  bool vehicle = false;             // the vehicle's host (the plant and SR run here)
  std::vector<std::string> links;   // the link services added (link_<peer>)
  std::vector<std::string> others;  // the services of other hosts, not started here
  RunTempDir dir;                   // holds the links' policy fragment while the kernel runs
};

// Cuts `graph` and `options` to host `host`'s part: the links added (their params: `enclave`, DIR/enclaves/<host>
// of `keys`, and `domain`), every other host's service skipped, the plant dropped off the vehicle's host, SR
// off there, the real-time clock (two kernels on two computers share no lockstep). The error is a usage error
// (exit 2): a host the graph does not declare ("did you mean"), a multi-host graph without `keys` (a link
// without DDS Security would take any peer), a keystore without this host's enclave.
[[nodiscard]] Result<HostPart, std::string> host_part(launch::LoadedLaunch& graph, kernel::KernelOptions& options,
                                                      std::string_view host,
                                                      const std::optional<std::filesystem::path>& keys);

}  // namespace rejuv::cli
