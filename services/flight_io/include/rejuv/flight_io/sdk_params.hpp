// flight_io::Params over a connected service's launch-graph params (sdk::Service::param). Header-only, so
// that the flight_io library itself does not depend on the SDK: only the services' main.cpp include it.
#pragma once

#include <limits>
#include <optional>
#include <string_view>

#include "rejuv/flight_io/params.hpp"
#include "rejuv/sdk/service.hpp"

namespace rejuv::flight_io {

// The Service must outlive the returned Params. A text param under a numeric name reads as NaN, which the
// readers refuse with the param's name.
[[nodiscard]] inline Params params_of(const sdk::Service& service) {
  return Params([&service](std::string_view name) -> std::optional<double> {
    if (!service.has_param(name)) return std::nullopt;
    return service.param(name, std::numeric_limits<double>::quiet_NaN());
  });
}

}  // namespace rejuv::flight_io
