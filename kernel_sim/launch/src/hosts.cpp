// The graph's hosts (idl/launch.proto Host, docs/across_hosts.md): which computer each service runs on. The
// vehicle's host is the first listed; a service that names none runs there. What crosses between hosts, and
// what the policy allows to, is the policy audit's (kernel_sim/policy hosts.hpp); here only the names.
#include <arpa/inet.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/launch/launch.hpp"
#include "validate.hpp"

namespace rejuv::launch {

namespace {
constexpr std::size_t kMaxHostName = 64;
// Cyclone DDS's participant lease where its config sets none (Discovery/LeaseDuration, default 10 s).
constexpr double kCycloneDefaultLeaseS = 10.0;

// A Cyclone duration ("10 s", "2.5s", "500 ms", "1 min", "inf"; a bare number is seconds) in seconds; nullopt
// for what Cyclone would refuse. "inf" is HUGE_VAL.
std::optional<double> cyclone_duration_s(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())) != 0) text.pop_back();
  std::size_t from = 0;
  while (from < text.size() && std::isspace(static_cast<unsigned char>(text[from])) != 0) ++from;
  text = text.substr(from);
  if (text == "inf") return HUGE_VAL;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !std::isfinite(v) || v < 0) return std::nullopt;
  std::string unit(end);
  unit.erase(0, unit.find_first_not_of(' '));
  if (unit.empty() || unit == "s") return v;
  if (unit == "ns") return v * 1e-9;
  if (unit == "us") return v * 1e-6;
  if (unit == "ms") return v * 1e-3;
  if (unit == "min") return v * 60;
  if (unit == "hr") return v * 3600;
  if (unit == "day") return v * 86400;
  return std::nullopt;
}

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

Result<void, LoadError> check_link_lease(const proto::Launch& g, const TextLocations& locs,
                                         const std::filesystem::path& path) {
  bool closes = false;  // a host whose kernel closes its link (Host.netns set: kernel_sim/kernel link_guard.hpp)
  for (const proto::Host& h : g.hosts()) closes = closes || !h.netns().empty();
  if (g.hosts_size() < 2 || !closes || !g.sr().enabled()) return {};
  double lease_s = kCycloneDefaultLeaseS;
  std::string lease_from = "Cyclone's default";
  const SourceLocation config_at = locs.locate({{"dds", -1}}, "config");
  if (!g.dds().config().empty()) {
    std::filesystem::path cfg(g.dds().config());
    if (cfg.is_relative()) cfg = path.parent_path() / cfg;
    std::stringstream text;
    text << std::ifstream(cfg).rdbuf();
    const std::string xml = text.str();
    const std::string open = "<LeaseDuration>", close = "</LeaseDuration>";
    if (const auto at = xml.find(open); at != std::string::npos) {
      const auto end = xml.find(close, at);
      const std::string value = xml.substr(at + open.size(), end == std::string::npos ? 0 : end - at - open.size());
      const auto parsed = cyclone_duration_s(value);
      if (!parsed) {
        return fail(semantic_error(config_at, "DDS config " + cfg.lexically_normal().string() + ": <LeaseDuration>" +
                                                  value + "</LeaseDuration> is not a duration such as \"10 s\""));
      }
      lease_s = *parsed;
      lease_from = "<LeaseDuration> of " + cfg.lexically_normal().string();
    }
  }
  // The secure interval lasts at least T_est (SC, before the check of (1)) and t_min (UPDATE); the check itself
  // ends only once the vehicle is in the safe set, so this is the part the graph fixes (docs/across_hosts.md).
  const double interval_s = g.sr().t_est_s() + g.sr().t_min_s();
  if (lease_s > interval_s) return {};
  return fail(semantic_error(
      locs.locate({{"sr", -1}}, "t_est_s"),
      "the links close for the secure interval, which lasts at least T_est " + num(g.sr().t_est_s()) + " s + t_min " +
          num(g.sr().t_min_s()) + " s = " + num(interval_s) + " s, but the DDS lease (" + lease_from + ") is " +
          num(lease_s) + " s: the hosts' participants would expire while the link is closed; set " +
          "<Discovery><LeaseDuration> in the graph's `dds.config` above " + num(interval_s) + " s, or shorten T_est"));
}

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
