// The boot parameters of a link between hosts (`link_<peer>`, rejuv_host_link; docs/across_hosts.md "The link"):
// the policy's link synthesis names its host and peer, `rejuv run --host` adds the enclave, the domain and both
// addresses, the kernel reads the enclave for the link's sandbox, and the link reads them all. Each key spelt here.
#pragma once

#include <string_view>

namespace rejuv::host_link_param {

inline constexpr std::string_view kHost = "host";                 // text: the host it runs on
inline constexpr std::string_view kPeer = "peer";                 // text: the host at its other end
inline constexpr std::string_view kEnclave = "enclave";           // text: KEYS/enclaves/<host>
inline constexpr std::string_view kDomain = "domain";             // number: the DDS domain
inline constexpr std::string_view kAddress = "address";           // text: its host's IPv4 address
inline constexpr std::string_view kPeerAddress = "peer_address";  // text: the peer's IPv4 address

}  // namespace rejuv::host_link_param
