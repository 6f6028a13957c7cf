// The graph across hosts (hosts.hpp, docs/across_hosts.md): placement, crossings and each host's DDS topics.
#include "rejuv/policy/hosts.hpp"

#include <algorithm>
#include <set>

namespace rejuv::policy {

Placement placement(const Policy& policy, const launch::LoadedLaunch& graph) {
  Placement out;
  const proto::Launch& g = graph.graph;
  if (g.hosts_size() == 0) {
    out.hosts.emplace_back();
  } else {
    for (const proto::Host& h : g.hosts()) out.hosts.push_back(h.name());
  }
  out.host_of.resize(policy.services().size());
  for (const proto::ServiceSpec& s : g.services()) {
    const auto id = policy.find_service(s.name());
    if (!id) continue;  // the coverage audit names it
    const std::string_view host = launch::host_of(g, s);
    const auto it = std::find(out.hosts.begin(), out.hosts.end(), host);
    // The launch loader refused a host not declared; "" (no hosts) is hosts[0].
    if (it != out.hosts.end()) out.host_of[id->value()] = static_cast<std::size_t>(it - out.hosts.begin());
  }
  return out;
}

std::vector<Crossing> crossings(const Policy& policy, const Placement& placement) {
  std::vector<Crossing> out;
  const auto& grants = policy.grants();
  for (std::size_t w = 0; w < grants.size(); ++w) {
    const Grant& gw = grants[w];
    if (policy.object(gw.object).kind != ObjectKind::Topic || !gw.rights.has(Right::Write)) continue;
    const auto hw = placement.of(gw.service);
    if (!hw) continue;
    for (std::size_t r = 0; r < grants.size(); ++r) {
      const Grant& gr = grants[r];
      if (gr.object != gw.object || !gr.rights.has(Right::Read)) continue;
      const auto hr = placement.of(gr.service);
      if (!hr || *hr == *hw) continue;
      ModeSet both;
      for (const SrMode m : kAllModes) {
        if (gw.modes.has(m) && gr.modes.has(m)) both.add(m);
      }
      out.push_back(Crossing{gw.object, w, r, *hw, *hr, both});
    }
  }
  return out;
}

std::string cross_host_dds_name(const Object& topic) {
  return std::string(launch::defaults::kDdsNamePrefix) + topic.name;
}

std::vector<HostTopics> host_topics(const Policy& policy, const Placement& placement) {
  std::vector<std::set<std::string>> pub(placement.hosts.size()), sub(placement.hosts.size());
  for (const Crossing& c : crossings(policy, placement)) {
    if (c.modes.empty()) continue;  // the two never hold their rights at once: nothing crosses
    const std::string name = cross_host_dds_name(policy.object(c.topic));
    pub[c.writer_host].insert(name);
    sub[c.reader_host].insert(name);
  }
  std::vector<HostTopics> out;
  for (std::size_t h = 0; h < placement.hosts.size(); ++h) {
    out.push_back(HostTopics{placement.hosts[h], {pub[h].begin(), pub[h].end()}, {sub[h].begin(), sub[h].end()}});
  }
  return out;
}

bool acts_in_secure_interval(const Policy& policy, ServiceId service) {
  const Service& s = policy.service(service);
  if (s.rejuvenation || s.level == ServiceLevel::Driver) return true;
  for (const Grant& g : policy.grants()) {
    if (g.service != service || !g.rights.has(Right::Write)) continue;
    for (const SrMode m : kAllModes) {
      if (m != SrMode::MC && g.modes.has(m)) return true;
    }
  }
  return false;
}

}  // namespace rejuv::policy
