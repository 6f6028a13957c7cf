// The graph across hosts (docs/across_hosts.md): which host each service of the policy runs on (the launch
// graph's `hosts` and each service's `host`), which topics cross between hosts, and in which modes. A topic
// with a writer on one host and a reader on another is a cross-host topic: it travels on DDS with DDS Security,
// whose permissions `rejuv keys hosts` writes from `host_topics`, and the `hosts` audit (audit.hpp) checks that
// the placement keeps the secure interval on the vehicle (§III: every link is closed in the SEI).
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rejuv/core/dds_name.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::policy {

// The host of every policy service the graph runs: hosts[0] is the vehicle's. A graph without `hosts` has one
// host, named "" (nothing crosses).
struct Placement {
  std::vector<std::string> hosts;
  std::vector<std::optional<std::size_t>> host_of;  // by ServiceId: index into hosts; nullopt = not in the graph

  [[nodiscard]] std::optional<std::size_t> of(ServiceId service) const { return host_of.at(service.value()); }
};
[[nodiscard]] Placement placement(const Policy& policy, const launch::LoadedLaunch& graph);

// One writer → reader pair of a topic on two different hosts, and the modes in which both hold their right
// (the modes in which a sample can cross; empty: the pair never meets).
struct Crossing {
  ObjectId topic;
  std::size_t grant_writer;  // indexes into Policy::grants()
  std::size_t grant_reader;
  std::size_t writer_host;
  std::size_t reader_host;
  ModeSet modes;
};
// Every crossing of the graph, in grant order (writer, then reader).
[[nodiscard]] std::vector<Crossing> crossings(const Policy& policy, const Placement& placement);

// What one host may publish and subscribe to on DDS (the permissions of its identity): the topics one of its
// services writes and a service on another host reads, and the reverse; DDS names under `naming` (the graph's:
// launch::dds_naming(graph.dds())), sorted, each once.
struct HostTopics {
  std::string host;
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};
[[nodiscard]] std::vector<HostTopics> host_topics(const Policy& policy, const Placement& placement, DdsNaming naming);

// The DDS name of a cross-host topic under `naming`, the graph's dds.ros2_names (launch::dds_naming):
// dds_topic_name(topic, naming), "rejuv/<topic>" or "rt/<topic>". The links name their DDS topics so, and the
// permissions of `rejuv keys hosts` grant these names.
[[nodiscard]] std::string cross_host_dds_name(const Object& topic, DdsNaming naming);

// A service that acts in the secure interval (§III, Fig. 1): it holds a Write right in RB, SC, UPDATE or CP
// (the safety chain: sensors, estimator, safety controller, setpoint update), or it is the rejuvenation service
// (the SR handler) or a driver (the output driver). Such a service must run on the vehicle's host: a link is
// closed in the SEI, and what the vehicle needs then cannot be on the other side of it.
[[nodiscard]] bool acts_in_secure_interval(const Policy& policy, ServiceId service);

// ---- The link between hosts (docs/across_hosts.md "The link") ----
// A host H that shares a cross-host topic with a peer host P runs a link service `link_<P>` (executable
// rejuv_host_link) under its own kernel: it writes into H's kernel what P's services write for H's readers, and
// reads from H's kernel what H's services write for P's readers, carrying both on DDS with DDS Security. It is a
// service of the policy like any other, holding those rights in MC only, so that the broker closes it in the
// secure interval (§III: every link is closed in the SEI) exactly as it closes any service's caps.
inline constexpr std::string_view kHostLinkExecutable = "rejuv_host_link";
inline constexpr std::string_view kHostLinkPrefix = "link_";
[[nodiscard]] std::string link_service_name(std::string_view peer);
// A service of the graph that is a link: named link_<host of the graph>, running rejuv_host_link.
[[nodiscard]] bool is_host_link(const proto::Launch& graph, const proto::ServiceSpec& service);

struct HostLink {
  std::size_t host = 0;          // where it runs (index into Placement::hosts)
  std::size_t peer = 0;          // the host at the other end
  std::vector<ObjectId> writes;  // into its kernel: written on `peer`, read on `host` (in MC), declaration order
  std::vector<ObjectId> reads;   // from its kernel: written on `host`, read on `peer` (in MC), declaration order
};
// The links host `host` runs: one per peer host sharing with it a topic that crosses in MC, in host order. A
// crossing that meets only in the secure interval carries nothing (the `hosts:mc-only` audit names it); links
// already in the policy are not counted as writers or readers.
[[nodiscard]] std::vector<HostLink> host_links(const Policy& policy, const Placement& placement, std::size_t host);

// The policy fragment that declares the links (idl/policy.proto text): each a `level: DRIVER` (never rolled back:
// restarted on a fault), `network_facing` service with Write on its `writes` and Read on its `reads`, in MC only.
[[nodiscard]] std::string links_policy_fragment(const Policy& policy, const Placement& placement,
                                                std::span<const HostLink> links);

// Adds the links of host `host` (a name of the graph's `hosts`) to a loaded graph: their policy fragment, written
// to `dir`/links_<host>.policy.pbtxt and named as one of the graph's policy fragments (so that the kernel loads,
// audits and compiles it with the rest), and a ServiceSpec each (`host`, rejuv_host_link, `rejuvenate: false`,
// its `uses`, the text params `host` and `peer`). Only one host's links: `link_<peer>` names one service per
// kernel, and each host's kernel runs its own. Nothing crossing: nothing added. The error says what failed (the
// policy does not load; the host is not one of the graph's; the fragment cannot be written).
struct AddedLinks {
  std::vector<HostLink> links;
  std::vector<std::string> hosts;  // Placement::hosts
  std::filesystem::path fragment;  // empty when no link was added
};
[[nodiscard]] Result<AddedLinks, std::string> add_host_links(launch::LoadedLaunch& graph, std::string_view host,
                                                             const std::filesystem::path& dir);

}  // namespace rejuv::policy
