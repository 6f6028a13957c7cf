// rejuv_output_driver: limits + inverse mixer as a driver-level process (services/output_driver/include/
// rejuv/services/output_driver/driver_node.hpp). No command line: started by the kernel.
#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/output_driver/driver_node.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  const flight_io::Params params = flight_io::params_of(svc);
  auto limits = flight_io::actuator_limits(params);
  if (!svc.require(limits, "bad params")) return 1;
  auto sr = flight_io::read(params, graph_values::kEnabled);
  if (!svc.require(sr, "bad params")) return 1;
  // The mixer of the vehicle the plant flies (flight/sim uses the same: plant.mixer().inverse()).
  const plant::Mixer mixer(flight::SimConfig::defaults().quad);
  services::DriverNode driver(mixer.inverse(), *limits, svc.mode());

  auto outputs = svc.advertise<rejuv_msg_ActuatorOutputs>("actuator_outputs");
  if (!svc.require(outputs, "actuator_outputs")) return 1;
  flight_io::FirstRefusalLog refuse(svc, "ignoring a message (the outputs in force stay)");
  // §IV-C: entering MC with SR on, Ū as checkpoint_p wrote it (through the Limits cap, never from a topic).
  const bool reads_limits = *sr && svc.cap("actuator_limits").has_value();
  const auto read_limits = [&] {
    std::array<std::byte, sizeof(flight_io::LimitsRecord)> record{};
    auto cell = svc.limits("actuator_limits");
    auto r = cell ? cell->read(record) : sdk::SdkResult<std::size_t>(std::unexpected(cell.error()));
    if (!r || *r != record.size()) {
      svc.log(sdk::LogLevel::Warn, "no restricted limits written before MC: the graph's Ū stays in force");
      return;
    }
    if (auto ok = driver.on_limits(record); !ok) refuse(ok.error());
  };
  auto modes = svc.subscribe<rejuv_msg_SrMode>("sr_mode", [&](const rejuv_msg_SrMode& m) {
    auto mode = flight_io::mode_from_message(m);
    if (!mode) return refuse(mode.error());
    if (*mode == SrMode::MC && reads_limits) read_limits();
    driver.on_mode(*mode);
  });
  auto controls = svc.subscribe<rejuv_msg_ActuatorControls>(
      "actuator_controls", [&](const rejuv_msg_ActuatorControls& m) {
        auto out = driver.on_controls(m, svc.now());
        if (!out) return refuse(out.error());
        (void)outputs->publish(*out);  // granted in every mode
      });
  if (!svc.require_all("subscribe", modes, controls)) return 1;
  return svc.run();
}

}  // namespace

int main() { return services::run_service(serve); }
