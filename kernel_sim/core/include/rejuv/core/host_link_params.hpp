// The boot parameters of a link between hosts (`link_<peer>`, rejuv_host_link; docs/across_hosts.md "The link"):
// the policy's link synthesis names its host and peer, `rejuv run --host` adds the enclave, the domain, both
// addresses and the graph's DDS naming, the kernel reads the enclave for the link's sandbox, and the link reads
// them all. Each key spelt here.
#pragma once

#include <string_view>

namespace rejuv::host_link_param {

inline constexpr std::string_view kHost = "host";                 // text: the host it runs on
inline constexpr std::string_view kPeer = "peer";                 // text: the host at its other end
inline constexpr std::string_view kEnclave = "enclave";           // text: KEYS/enclaves/<host>
inline constexpr std::string_view kDomain = "domain";             // number: the DDS domain
inline constexpr std::string_view kAddress = "address";           // text: its host's IPv4 address
inline constexpr std::string_view kPeerAddress = "peer_address";  // text: the peer's IPv4 address
// text: the DDS names of the carried topics, to_string(DdsNaming) of the graph's dds.ros2_names (rejuv/core/dds_name.hpp):
// "rejuv" (rejuv/<topic>, the IDL type name) or "ros2" (rt/<topic>, rejuv_msgs::msg::dds_::T_); unset = "rejuv".
inline constexpr std::string_view kDdsNames = "dds_names";

}  // namespace rejuv::host_link_param
