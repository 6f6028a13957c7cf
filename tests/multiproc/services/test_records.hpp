// What the purpose-built test services share (image_service.cpp, tests/security/services/attack_service.cpp):
// the generic record they publish — SensorBaro, its three numbers meaning what each service's header says —
// and the exit of a service whose set-up failed.
#pragma once

#include <cstdint>
#include <string>

#include "rejuv/sdk/service.hpp"

namespace rejuv::test_services {

using Record = rejuv_msg_SensorBaro;

// pressure_pa of the record image_service's `hooked` role publishes from on_restored (no sequence number is <
// 0).
inline constexpr double kRestoredMark = -1;

// A record stamped now: pressure_pa = a, altitude_m = b, temperature_c = c.
inline Record record(const sdk::Service& svc, double a, double b, double c) {
  Record r{};
  r.timestamp_ns = static_cast<std::uint64_t>(svc.now().count());
  r.pressure_pa = a;
  r.altitude_m = b;
  r.temperature_c = c;
  return r;
}

// Logs `what` at Error and returns the services' set-up failure exit code (3).
inline int fail(sdk::Service& svc, const std::string& what) {
  svc.log(sdk::LogLevel::Error, what);
  return 3;
}

}  // namespace rejuv::test_services
