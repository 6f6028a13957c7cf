// The graph's hosts (idl/launch.proto Host, docs/across_hosts.md): which computer each service runs on. The
// vehicle's host is the first listed; a service that names none runs there. What crosses between hosts, and
// what the policy allows to, is the policy audit's (kernel_sim/policy hosts.hpp); here only the names.
#include <arpa/inet.h>

#include <string>
#include <vector>

#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/launch/launch.hpp"
#include "validate.hpp"

namespace rejuv::launch {

namespace {
constexpr std::size_t kMaxHostName = 64;

// A host's name is the CN of its DDS Security identity and a folder of the keystore: letters, digits, '_', '-'.
bool is_host_name(std::string_view s) {
  if (s.empty() || s.size() > kMaxHostName) return false;
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-';
    if (!ok) return false;
  }
  return true;
}
}  // namespace

std::string_view vehicle_host(const proto::Launch& graph) {
  return graph.hosts_size() == 0 ? std::string_view{} : std::string_view(graph.hosts(0).name());
}

std::string_view host_of(const proto::Launch& graph, const proto::ServiceSpec& service) {
  return service.host().empty() ? vehicle_host(graph) : std::string_view(service.host());
}

namespace detail {

Result<void, LoadError> check_hosts(const proto::Launch& g, const TextLocations& locs) {
  std::vector<std::string> names;
  std::vector<std::string> addresses;
  for (int i = 0; i < g.hosts_size(); ++i) {
    const proto::Host& h = g.hosts(i);
    if (!is_host_name(h.name())) {
      return fail(semantic_error(locs.locate({{"hosts", i}}, "name"),
                                 h.name().empty() ? std::string("host without a `name`")
                                                  : "host name \"" + h.name() +
                                                        "\" must be 1…64 letters, digits, '_' or '-' (it is the CN "
                                                        "of the host's DDS Security identity)"));
    }
    for (const std::string& n : names) {
      if (n == h.name()) {
        return fail(semantic_error(locs.locate({{"hosts", i}}, "name"), "duplicate host \"" + h.name() + "\""));
      }
    }
    in_addr addr{};
    if (::inet_pton(AF_INET, h.address().c_str(), &addr) != 1) {
      return fail(semantic_error(locs.locate({{"hosts", i}}, "address"),
                                 "host \"" + h.name() + "\": `address` must be an IPv4 address such as \"10.0.0.1\", got \"" +
                                     h.address() + "\""));
    }
    for (std::size_t j = 0; j < addresses.size(); ++j) {
      if (addresses[j] == h.address()) {
        return fail(semantic_error(locs.locate({{"hosts", i}}, "address"),
                                   "host \"" + h.name() + "\" has the address " + h.address() + " of host \"" +
                                       names[j] + "\""));
      }
    }
    names.push_back(h.name());
    addresses.push_back(h.address());
  }
  for (int i = 0; i < g.services_size(); ++i) {
    const proto::ServiceSpec& s = g.services(i);
    if (s.host().empty()) continue;
    if (names.empty()) {
      return fail(semantic_error(locs.locate({{"services", i}}, "host"),
                                 "service \"" + s.name() + "\" names host \"" + s.host() +
                                     "\", but the graph declares no `hosts { name address }`"));
    }
    bool known = false;
    for (const std::string& n : names) known = known || n == s.host();
    if (!known) {
      return fail(semantic_error(locs.locate({{"services", i}}, "host"),
                                 "service \"" + s.name() + "\" names host \"" + s.host() +
                                     "\", which is not in the graph's `hosts`" + did_you_mean(s.host(), names)));
    }
  }
  return {};
}

}  // namespace detail
}  // namespace rejuv::launch
