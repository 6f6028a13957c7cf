// One start-up for every service's main(): connect to the kernel on fd 3 / fd 4, report a
// failed connection, hand the Service to the service's own set-up, return its exit code.
//
//   int main() {
//     return rejuv::sdk::run_service([](rejuv::sdk::Service& svc) {
//       auto out = svc.advertise<rejuv_msg_Setpoint>("setpoint");
//       if (!svc.require(out, "setpoint")) return 1;
//       ...                                  // subscriptions and timers, which live until run() returns
//       return svc.run();                    // Ready, then the event loop until Shutdown
//     });
//   }
//
// The body makes its handles and callbacks as locals and ends with `return svc.run();`, so that everything
// the callbacks capture lives as long as the event loop.
#pragma once

#include <functional>

#include "rejuv/sdk/service.hpp"

namespace rejuv::sdk {

// A service's set-up and event loop: returns the process's exit code (usually svc.run()).
using ServiceMain = std::function<int(Service&)>;

// Connects (Service::connect(options)); on failure prints why (report_connect_failure) and returns 2,
// otherwise returns body(service). The Service lives until body returns.
[[nodiscard]] int run_service(const ServiceMain& body, const ConnectOptions& options = {});

}  // namespace rejuv::sdk
