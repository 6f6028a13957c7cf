// `rejuv run --host` (host_part.hpp).
#include "host_part.hpp"

#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <system_error>
#include <utility>

#include "keystore.hpp"
#include "rejuv/core/host_link_params.hpp"
#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/policy/hosts.hpp"

namespace rejuv::cli {

Result<RunTempDir, std::string> RunTempDir::create(std::string_view prefix) {
  std::error_code ec;
  const std::filesystem::path base = std::filesystem::temp_directory_path(ec);
  if (ec) return fail("no temporary folder: " + ec.message());
  std::string pattern = (base / (std::string(prefix) + "XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) return fail("cannot make a folder under " + base.string());
  return RunTempDir(std::filesystem::path(pattern));
}

RunTempDir& RunTempDir::operator=(RunTempDir&& other) noexcept {
  if (this != &other) {
    RunTempDir dropped(std::move(*this));
    path_ = std::exchange(other.path_, {});
  }
  return *this;
}

RunTempDir::~RunTempDir() {
  if (path_.empty()) return;
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

Result<HostPart, std::string> host_part(launch::LoadedLaunch& graph, kernel::KernelOptions& options,
                                        std::string_view host, const std::optional<std::filesystem::path>& keys) {
  proto::Launch& g = graph.graph;
  std::vector<std::string> names;
  for (const proto::Host& h : g.hosts()) names.push_back(h.name());
  if (names.empty()) {
    return fail("--host " + std::string(host) + ": " + graph.path.string() + " declares no `hosts`; run it without --host");
  }
  if (std::find(names.begin(), names.end(), host) == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    return fail("--host: the graph has no host '" + std::string(host) + "'" + did_you_mean(host, names) +
                "; its hosts: " + list);
  }
  if (names.size() > 1 && !keys) {
    return fail("--host " + std::string(host) + " needs --keys DIR: the graph spans " + std::to_string(names.size()) +
                " hosts, and its links carry topics between them only with DDS Security (an unauthenticated link "
                "would take any peer); make DIR with `rejuv keys init DIR` and `rejuv keys hosts DIR --launch GRAPH`");
  }
  std::filesystem::path enclave;
  if (keys) {
    std::error_code ec;
    enclave = std::filesystem::absolute(keys::enclave_dir(*keys, host), ec);
    const std::filesystem::path permissions = enclave / keys::enclave_file::kPermissions;
    if (ec || !std::filesystem::is_regular_file(permissions, ec)) {
      return fail("--keys " + keys->string() + ": no enclave of host '" + std::string(host) + "' (" +
                  permissions.string() + "); make it with `rejuv keys hosts " + keys->string() + " --launch GRAPH`");
    }
  }
  auto dir = RunTempDir::create("rejuv-host-");
  if (!dir) return fail("--host: " + dir.error());
  auto added = policy::add_host_links(graph, host, dir->path());
  if (!added) return fail("--host " + std::string(host) + ": " + added.error());
  const std::uint32_t domain = options.dds_domain.value_or(g.dds().domain_id());
  HostPart part{.host = std::string(host), .vehicle = host == launch::vehicle_host(g), .links = {}, .others = {},
                .dir = std::move(*dir)};
  for (proto::ServiceSpec& s : *g.mutable_services()) {
    if (launch::host_of(g, s) != host) {
      part.others.push_back(s.name());
      continue;
    }
    if (!policy::is_host_link(g, s)) continue;
    part.links.push_back(s.name());
    proto::Param& e = *s.add_params();
    e.set_name(std::string(host_link_param::kEnclave));
    e.set_text(enclave.string());
    proto::Param& d = *s.add_params();
    d.set_name(std::string(host_link_param::kDomain));
    d.set_number(domain);
    // The topics' DDS names, as the permissions of `rejuv keys hosts` grant them (policy::host_topics).
    proto::Param& n = *s.add_params();
    n.set_name(std::string(host_link_param::kDdsNames));
    n.set_text(std::string(to_string(launch::dds_naming(g.dds()))));
    std::string peer;
    for (const proto::Param& p : s.params()) {
      if (p.name() == host_link_param::kPeer) peer = p.text();
    }
    for (const auto& [key, name] : {std::pair{host_link_param::kAddress, std::string(host)}, std::pair{host_link_param::kPeerAddress, peer}}) {
      proto::Param& a = *s.add_params();
      a.set_name(std::string(key));
      for (const proto::Host& h : g.hosts()) {
        if (h.name() == name) a.set_text(h.address());
      }
    }
  }
  for (const std::string& other : part.others) {
    if (std::find(options.skip_services.begin(), options.skip_services.end(), other) == options.skip_services.end()) {
      options.skip_services.push_back(other);
    }
  }
  // Two kernels on two computers: each keeps the wall clock (no lockstep spans hosts).
  options.clock = kernel::ClockMode::Realtime;
  if (!part.vehicle) {
    // The plant is the vehicle's world; SR is the vehicle's cycle (the audit keeps the rejuvenation service and
    // every service that acts in the secure interval on the vehicle's host): this host's kernel stays in MC.
    g.clear_plant();
    options.no_sr = true;
  }
  return part;
}

}  // namespace rejuv::cli
