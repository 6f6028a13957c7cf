// The example at the top of rejuv/sdk/service.hpp, compiled here as it is written there (between the markers
// below), and checked to be the same text: the header cannot show an API the SDK no longer has.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>

#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"

namespace {

// ---- example begin ----
[[maybe_unused]] int main() {
  return rejuv::sdk::run_service([](rejuv::sdk::Service& svc) {  // rejuv/sdk/run.hpp: Hello/Boot
    const double gain = svc.param("gain", 1.0);
    auto out = svc.advertise<rejuv_msg_ActuatorControls>("actuator_controls");
    if (!svc.require(out, "actuator_controls")) return 1;
    auto est = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state");
    if (!svc.require(est, "vehicle_state")) return 1;
    auto tick = svc.every(std::chrono::milliseconds(4), [&] {
      if (!est->updated()) return;
      const rejuv_msg_VehicleStateEstimate& x = est->copy();
      rejuv_msg_ActuatorControls u{};
      u.timestamp_ns = x.timestamp_ns;
      u.thrust_N = gain * -x.v_N_m_s[2];
      (void)out->publish(u);
    });
    if (!svc.require(tick, "timer")) return 1;
    return svc.run();  // Ready, then the event loop until Shutdown; the exit code
  });
}
// ---- example end ----

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The lines of `text` from the first that starts with `first` up to the first after it that is `last`
// (inclusive), each with its first `strip` characters removed.
std::string lines_between(const std::string& text, const std::string& first, const std::string& last,
                          std::size_t strip) {
  std::istringstream in(text);
  std::string out;
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (!inside && line.rfind(first, 0) == 0) inside = true;
    if (!inside) continue;
    if (line.rfind("[[maybe_unused]] ", 0) == 0) line = line.substr(17);  // here only: it is never called
    out += (line.size() > strip ? line.substr(strip) : "") + "\n";
    if (line == last) break;
  }
  return out;
}

TEST(SdkHeaderExample, TheHeadersExampleIsTheCodeCompiledHere) {
  const std::string header = read(std::string(REJUV_SOURCE_DIR) + "/services/sdk/include/rejuv/sdk/service.hpp");
  const std::string here = read(std::string(REJUV_SOURCE_DIR) + "/tests/unit/kernel/sdk_example_test.cpp");
  // In the header each line is the code behind "//   " (5 characters).
  const std::string shown = lines_between(header, "//   int main() {", "//   }", 5);
  const std::string compiled = lines_between(here, "[[maybe_unused]] int main() {", "}", 0);
  ASSERT_GT(compiled.size(), 200U) << "the example compiled here was not found";
  EXPECT_EQ(shown, compiled) << "the example in service.hpp differs from the one compiled here";
}

}  // namespace
