// rejuv_host_link's logic apart from the SDK and Cyclone (host_link.hpp).
#include "rejuv/services/host_link/host_link.hpp"

namespace rejuv::services::host_link {

std::string cyclone_config(cyclone::ParticipantConfig settings) {
  // Announced every second, not every 30 s: the vehicle's end opens only in MC (its host closes the link below DDS
  // in the secure interval), so discovery and the security handshake happen in MC windows.
  settings.spdp_interval = "1s";
  return cyclone::config_xml(settings);
}

bool McWindow::observe(bool in_mc, std::int64_t now_ns) {
  const bool began = in_mc && !in_mc_;
  if (began) began_ns_ = now_ns;
  in_mc_ = in_mc;
  return began;
}

}  // namespace rejuv::services::host_link
