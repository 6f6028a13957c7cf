// The companion's monitor of tests/across_hosts (quad_companion.launch.pbtxt): a tiny SDK service on the
// companion host that reads the vehicle's state estimate, which reaches it only through the two links
// (vehicle → DDS with DDS Security → companion), and logs how many it got, once a second:
//   "vehicle states received: N (in MC: M)"
#include <chrono>

#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"

int main() {
  using namespace rejuv;
  return sdk::run_service([](sdk::Service& svc) {
    std::uint64_t received = 0, in_mc = 0;
    auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state", [&](const rejuv_msg_VehicleStateEstimate&) {
      ++received;
      if (svc.mode() == SrMode::MC) ++in_mc;
    });
    if (!svc.require(state, "vehicle_state")) return 1;
    auto report = svc.every(std::chrono::seconds(1), [&] {
      svc.logf(sdk::LogLevel::Info, "vehicle states received: %llu (in MC: %llu)", static_cast<unsigned long long>(received),
               static_cast<unsigned long long>(in_mc));
    });
    if (!svc.require(report, "report timer")) return 1;
    return svc.run();
  });
}
