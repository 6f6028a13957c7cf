#include "rejuv/sdk/run.hpp"

namespace rejuv::sdk {

int run_service(const ServiceMain& body, const ConnectOptions& options) {
  auto connected = Service::connect(options);
  if (!connected) return report_connect_failure(connected.error());
  return body(**connected);
}

}  // namespace rejuv::sdk
