// The graph across hosts (docs/across_hosts.md): which host each service of the policy runs on (the launch
// graph's `hosts` and each service's `host`), which topics cross between hosts, and in which modes. A topic
// with a writer on one host and a reader on another is a cross-host topic: it travels on DDS with DDS Security,
// whose permissions `rejuv keys hosts` writes from `host_topics`, and the `hosts` audit (audit.hpp) checks that
// the placement keeps the secure interval on the vehicle (§III: every link is closed in the SEI).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

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
// services writes and a service on another host reads, and the reverse; DDS names, sorted, each once.
struct HostTopics {
  std::string host;
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};
[[nodiscard]] std::vector<HostTopics> host_topics(const Policy& policy, const Placement& placement);

// The DDS name of a cross-host topic: "rejuv/<topic>" (as a bridge's default, launch::dds_name).
[[nodiscard]] std::string cross_host_dds_name(const Object& topic);

// A service that acts in the secure interval (§III, Fig. 1): it holds a Write right in RB, SC, UPDATE or CP
// (the safety chain: sensors, estimator, safety controller, setpoint update), or it is the rejuvenation service
// (the SR handler) or a driver (the output driver). Such a service must run on the vehicle's host: a link is
// closed in the SEI, and what the vehicle needs then cannot be on the other side of it.
[[nodiscard]] bool acts_in_secure_interval(const Policy& policy, ServiceId service);

}  // namespace rejuv::policy
