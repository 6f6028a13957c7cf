// rejuv_host_link (docs/across_hosts.md "The link"): a host's end of its link to one peer host. Started by the
// host's kernel as the service link_<peer> (kernel_sim/policy hosts.hpp add_host_links), it holds in MC only
// Write on each topic the peer's services write for this host's readers and Read on each topic this host's
// services write for the peer's readers; it learns which from its own caps. It runs one Cyclone DDS participant
// with DDS Security (the host's enclave of `rejuv keys hosts`): a DDS writer per topic it reads from its kernel
// and a DDS reader per topic it writes to its kernel, of the topic's compiled IDL type, whose C struct's bytes are
// what the kernel carries. Their DDS names follow the graph's dds.ros2_names (its param dds_names, set by its
// kernel): `rejuv/<topic>` of the IDL type name, or `rt/<topic>` of `rejuv_msgs::msg::dds_::T_` (msgs::dds_topic). Remote bytes are deserialized here (by Cyclone, against the IDL
// type), never in the kernel: the kernel gets a payload of the topic's size, through the capability check.
//
// The secure interval (§III, §IV-D): the kernel revokes the link's caps outside MC, so nothing it publishes is
// routed and nothing is delivered to it; DDS samples that arrive meanwhile wait in its readers, and on entering
// MC every one whose source timestamp is before MC began (written while the link was closed) is dropped.
#pragma once

#include <cstdint>
#include <string>

#include "rejuv/core/cyclone_xml.hpp"

namespace rejuv::services::host_link {

// The Cyclone XML of the link (<CycloneDDS> with <Security>, cyclone::config_xml): the host's own address (its
// interface), the addresses of both ends as unicast peers (no multicast: a link is point to point), the enclave
// of `rejuv keys hosts` (KEYS/enclaves/<host>) and the private key's PEM as the kernel handed it over
// (wire::kHostLinkKeyFd: the key file is its owner's only; empty: the enclave's key.pem by its path). Its
// spdp_interval is the link's own: one second.
[[nodiscard]] std::string cyclone_config(cyclone::ParticipantConfig settings);

// The link's closing rule for samples from the peer: admitted only in MC, and only when written (their DDS
// source timestamp) after the MC window began; a sample written while the link was closed is dropped.
class McWindow {
 public:
  // The mode seen now; `now_ns` is the wall clock (the clock DDS stamps samples with) [ns since the epoch].
  // Returns true when MC has just begun (the caller then drops what was queued before it).
  bool observe(bool in_mc, std::int64_t now_ns);
  [[nodiscard]] bool open() const { return in_mc_; }
  // Whether a sample stamped `source_ns` may go to the kernel now.
  [[nodiscard]] bool admits(std::int64_t source_ns) const { return in_mc_ && source_ns >= began_ns_; }
  [[nodiscard]] std::int64_t began_ns() const { return began_ns_; }

 private:
  bool in_mc_ = false;
  std::int64_t began_ns_ = 0;
};

}  // namespace rejuv::services::host_link
