// The graph across hosts (hosts.hpp, docs/across_hosts.md): placement, crossings and each host's DDS topics.
#include "rejuv/core/host_link_params.hpp"
#include "rejuv/policy/hosts.hpp"

#include <algorithm>
#include <fstream>
#include <set>
#include <utility>

#include "rejuv/core/dds_name.hpp"

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

std::string cross_host_dds_name(const Object& topic, DdsNaming naming) { return dds_topic_name(topic.name, naming); }

std::vector<HostTopics> host_topics(const Policy& policy, const Placement& placement, DdsNaming naming) {
  std::vector<std::set<std::string>> pub(placement.hosts.size()), sub(placement.hosts.size());
  for (const Crossing& c : crossings(policy, placement)) {
    if (c.modes.empty()) continue;  // the two never hold their rights at once: nothing crosses
    const std::string name = cross_host_dds_name(policy.object(c.topic), naming);
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

namespace rejuv::policy {

std::string link_service_name(std::string_view peer) { return std::string(kHostLinkPrefix) + std::string(peer); }

bool is_host_link(const proto::Launch& graph, const proto::ServiceSpec& service) {
  if (std::filesystem::path(service.executable()).filename() != kHostLinkExecutable) return false;
  return std::any_of(graph.hosts().begin(), graph.hosts().end(),
                     [&](const proto::Host& h) { return service.name() == link_service_name(h.name()); });
}

namespace {

// A link already in the policy (link_<host>): not a writer or reader of its own.
bool named_as_link(const Placement& placement, std::string_view name) {
  return std::any_of(placement.hosts.begin(), placement.hosts.end(),
                     [&](const std::string& h) { return !h.empty() && name == link_service_name(h); });
}

void add_once(std::vector<ObjectId>& ids, ObjectId id) {
  const auto at = std::lower_bound(ids.begin(), ids.end(), id);
  if (at == ids.end() || *at != id) ids.insert(at, id);
}

}  // namespace

std::vector<HostLink> host_links(const Policy& policy, const Placement& placement, std::size_t host) {
  std::vector<HostLink> by_peer(placement.hosts.size());
  for (std::size_t p = 0; p < by_peer.size(); ++p) by_peer[p] = HostLink{.host = host, .peer = p, .writes = {}, .reads = {}};
  for (const Crossing& c : crossings(policy, placement)) {
    if (!c.modes.has(SrMode::MC)) continue;
    const Grant& w = policy.grants()[c.grant_writer];
    const Grant& r = policy.grants()[c.grant_reader];
    if (named_as_link(placement, policy.service(w.service).name) ||
        named_as_link(placement, policy.service(r.service).name)) {
      continue;
    }
    if (c.reader_host == host) add_once(by_peer[c.writer_host].writes, c.topic);
    if (c.writer_host == host) add_once(by_peer[c.reader_host].reads, c.topic);
  }
  std::vector<HostLink> out;
  for (HostLink& l : by_peer) {
    if (!l.writes.empty() || !l.reads.empty()) out.push_back(std::move(l));
  }
  return out;
}

std::string links_policy_fragment(const Policy& policy, const Placement& placement, std::span<const HostLink> links) {
  std::string out =
      "# The links between hosts (docs/across_hosts.md \"The link\"), made by `rejuv run --host` from the policy\n"
      "# and the graph's hosts: each carries on DDS, in MC only, what crosses between its host and one peer.\n";
  for (const HostLink& l : links) {
    const std::string name = link_service_name(placement.hosts[l.peer]);
    out += "services { name: \"" + name + "\" level: DRIVER network_facing: true }\n";
    for (const ObjectId t : l.writes) {
      out += "grants { service: \"" + name + "\" object: \"" + policy.object(t).name + "\" rights: \"W\" modes: MC }\n";
    }
    for (const ObjectId t : l.reads) {
      out += "grants { service: \"" + name + "\" object: \"" + policy.object(t).name + "\" rights: \"R\" modes: MC }\n";
    }
  }
  return out;
}

Result<AddedLinks, std::string> add_host_links(launch::LoadedLaunch& graph, std::string_view host,
                                               const std::filesystem::path& dir) {
  auto policy = load_policy(graph.policy_path, graph.policy_includes);
  if (!policy) return fail(policy.error().to_string());
  const Placement place = placement(*policy, graph);
  const auto at = std::find(place.hosts.begin(), place.hosts.end(), host);
  if (at == place.hosts.end()) return fail("the graph has no host '" + std::string(host) + "'");
  AddedLinks added{.links = host_links(*policy, place, static_cast<std::size_t>(at - place.hosts.begin())),
                   .hosts = place.hosts,
                   .fragment = {}};
  if (added.links.empty()) return added;
  added.fragment = dir / ("links_" + std::string(host) + ".policy.pbtxt");
  {
    std::ofstream f(added.fragment, std::ios::trunc);
    f << links_policy_fragment(*policy, place, added.links);
    if (!f.flush()) return fail("cannot write " + added.fragment.string());
  }
  graph.policy_includes.push_back(
      ExtraFragment{.path = added.fragment, .named_at = SourceLocation{.file = added.fragment.string(), .line = 1, .column = 1}});
  for (const HostLink& l : added.links) {
    proto::ServiceSpec& s = *graph.graph.add_services();
    s.set_name(link_service_name(place.hosts[l.peer]));
    s.set_executable(std::string(kHostLinkExecutable));
    s.set_rejuvenate(false);
    s.set_host(std::string(host));
    for (const ObjectId t : l.writes) {
      proto::Use& u = *s.add_uses();
      u.set_object(policy->object(t).name);
      u.set_rights("W");
    }
    for (const ObjectId t : l.reads) {
      proto::Use& u = *s.add_uses();
      u.set_object(policy->object(t).name);
      u.set_rights("R");
    }
    for (const auto& [key, value] : {std::pair{host_link_param::kHost, std::string(host)}, std::pair{host_link_param::kPeer, place.hosts[l.peer]}}) {
      proto::Param& p = *s.add_params();
      p.set_name(std::string(key));
      p.set_text(value);
    }
  }
  return added;
}

}  // namespace rejuv::policy
