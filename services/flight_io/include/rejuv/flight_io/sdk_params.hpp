// flight_io::Params over a connected service's launch-graph params (sdk::Service::param). Header-only, so
// that the flight_io library itself does not depend on the SDK: only the services' main.cpp include it.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "rejuv/flight_io/mission_record.hpp"

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
  return Params([&service](std::string_view name) { return service.param_value(name); });
}

// The mission record in the Persistent cell `object` (mission_record.hpp), read if the current mode grants this
// service Read on it (nullopt otherwise, and for a cell never written). Errors are the SDK's or the decoder's.
[[nodiscard]] inline Result<std::optional<MissionRecord>, std::string> read_mission_cell(sdk::Service& service,
                                                                                       std::string_view object) {
  auto found = service.cap(object);
  if (!found || !(*found)->rights_in(service.mode()).has(Right::Read)) return std::optional<MissionRecord>{};
  auto cell = service.persistent(object);
  if (!cell) return fail(cell.error().to_string());
  MissionRecordBytes bytes{};
  auto read = cell->read(bytes);
  if (!read) return fail(read.error().to_string());
  if (*read != bytes.size()) {
    return fail("expected " + std::to_string(bytes.size()) + " bytes, got " + std::to_string(*read));
  }
  auto record = decode_mission_record(bytes);
  if (!record) return fail(record.error().to_string());
  return std::move(*record);
}

// Writes `record` into the Persistent cell `object` if the current mode grants this service Write on it.
// False, and nothing written, when it does not (an honest service causes no denial).
[[nodiscard]] inline Result<bool, std::string> write_mission_cell(sdk::Service& service, std::string_view object,
                                                                 const MissionRecord& record) {
  auto found = service.cap(object);
  if (!found || !(*found)->rights_in(service.mode()).has(Right::Write)) return false;
  auto cell = service.persistent(object);
  if (!cell) return fail(cell.error().to_string());
  const MissionRecordBytes bytes = encode_mission_record(record);
  auto written = cell->write(bytes);
  if (!written) return fail(written.error().to_string());
  return true;
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
