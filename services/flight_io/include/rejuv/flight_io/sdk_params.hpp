// flight_io::Params over a connected service's launch-graph params (sdk::Service::param). Header-only, so
// that the flight_io library itself does not depend on the SDK: only the services' main.cpp include it.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
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

// A service's handler of refused inputs: logs the first one at Warn as "<what>: <failure>" and only counts
// the rest, so that a stream of bad messages does not flood the log (the service keeps its last good input).
// The Service must outlive it.
class FirstRefusalLog {
 public:
  FirstRefusalLog(sdk::Service& service, std::string_view what) : service_(service), what_(what) {}
  void operator()(const InputFailure& failure) {
    if (refused_++ == 0) service_.log(sdk::LogLevel::Warn, what_ + ": " + failure.to_string());
  }

 private:
  sdk::Service& service_;
  std::string what_;
  std::uint64_t refused_ = 0;
};

}  // namespace rejuv::flight_io
