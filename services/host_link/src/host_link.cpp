// rejuv_host_link's logic apart from the SDK and Cyclone (host_link.hpp).
#include "rejuv/services/host_link/host_link.hpp"

#include "rejuv/core/cyclone_xml.hpp"

namespace rejuv::services::host_link {

std::string cyclone_config(const CycloneSettings& s) {
  // Announced every second, not every 30 s: the vehicle's end opens only in MC (its host closes the link below DDS
  // in the secure interval), so discovery and the security handshake happen in MC windows.
  return cyclone::config_xml(cyclone::ParticipantConfig{.address = s.address,
                                                        .peers = s.peers,
                                                        .enclave = s.enclave,
                                                        .private_key_pem = s.private_key_pem,
                                                        .spdp_interval = "1s"});
}

bool McWindow::observe(bool in_mc, std::int64_t now_ns) {
  const bool began = in_mc && !in_mc_;
  if (began) began_ns_ = now_ns;
  in_mc_ = in_mc;
  return began;
}

}  // namespace rejuv::services::host_link
