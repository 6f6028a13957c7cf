// rejuv_checkpoint_p: the rollback handler as a process (services/checkpoint_p/include/rejuv/services/
// checkpoint_p/sr_manager.hpp). This file binds SrEffects to the SDK and the handler to a kernel timer and
// the topics. No command line: started by the kernel.
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <span>
#include <string>
#include <utility>

#include "rejuv/flight_io/sdk_params.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/checkpoint_p/sr_manager.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;

services::EffectFailure failure_of(const sdk::Error& error) {
  return services::EffectFailure{.message = error.to_string()};
}

// The kernel calls of §V through the SDK: the caps `sr_mode_control` (Mode), `checkpoint` (Checkpoint),
// `actuator_limits` (Limits) and the topic `setpoint_update_request`.
class SdkEffects final : public services::SrEffects {
 public:
  SdkEffects(sdk::Service& svc, sdk::Publisher<rejuv_msg_SetpointUpdateRequest> requests)
      : svc_(svc), requests_(requests) {}

  [[nodiscard]] Nanos now() const override { return svc_.now(); }
  [[nodiscard]] Epoch epoch() const override { return svc_.epoch(); }

  Result<void, services::EffectFailure> request_mode(SrMode mode) override {
    auto control = svc_.mode_control("sr_mode_control");
    if (!control) return fail(failure_of(control.error()));
    if (auto r = control->request(mode); !r) return fail(failure_of(r.error()));
    return {};
  }
  Result<void, services::EffectFailure> request_setpoint_update(
      const rejuv_msg_SetpointUpdateRequest& m) override {
    auto r = requests_.publish(m);
    if (!r) return fail(failure_of(r.error()));
    return {};
  }
  Result<flight::CheckpointReturn, services::EffectFailure> checkpoint() override {
    auto r = svc_.checkpoint("checkpoint");
    if (!r) return fail(failure_of(r.error()));
    switch (r->kind) {
      case sdk::CheckpointOutcome::Kind::Taken:
        return flight::CheckpointReturn{flight::CheckpointTaken{r->generation}};
      case sdk::CheckpointOutcome::Kind::Restored:
        return flight::CheckpointReturn{flight::CheckpointRestored{r->generation, r->epoch}};
    }
    return fail(services::EffectFailure{.message = "checkpoint: unknown outcome"});
  }
  Result<void, services::EffectFailure> arm_rejuvenation_timer(Nanos after) override {
    // Once, T_MC from now: do_timer(T_MC, 0) of §V-A.
    auto rejuvenation = svc_.rejuvenation("checkpoint");
    if (!rejuvenation) return fail(failure_of(rejuvenation.error()));
    if (auto r = rejuvenation->arm_timer(after); !r) return fail(failure_of(r.error()));
    return {};
  }
  Result<void, services::EffectFailure> write_limits(const flight_io::LimitsRecord& record) override {
    const auto bytes = flight_io::limits_bytes(record);
    auto cell = svc_.limits("actuator_limits");
    if (!cell) return fail(failure_of(cell.error()));
    if (auto r = cell->write(std::span<const std::byte>(bytes)); !r) return fail(failure_of(r.error()));
    return {};
  }
  void log(services::Severity severity, std::string_view text) override {
    switch (severity) {
      case services::Severity::Debug: return svc_.log(sdk::LogLevel::Debug, text);
      case services::Severity::Info: return svc_.log(sdk::LogLevel::Info, text);
      case services::Severity::Warn: return svc_.log(sdk::LogLevel::Warn, text);
      case services::Severity::Error: return svc_.log(sdk::LogLevel::Error, text);
    }
  }

 private:
  sdk::Service& svc_;
  sdk::Publisher<rejuv_msg_SetpointUpdateRequest> requests_;
};

// The service's set-up and event loop; main() is the start-up every service shares (services/service_main).
int serve(sdk::Service& svc) {
  const flight_io::Params params = flight_io::params_of(svc);
  auto cycle = flight_io::sr_cycle_params(params);
  if (!svc.require(cycle, "bad params")) return 1;
  if (cycle->tracking.sr == flight::SrSwitch::Off) {
    // Without SR the mode is MC for ever and this service holds none of its kernel caps there.
    svc.log(sdk::LogLevel::Info, std::string(graph_values::kEnabled.name) + " = 0: no rollback handler runs");
    return svc.run();
  }
  auto start = flight_io::control_start(params);
  if (!svc.require(start, "bad params")) return 1;
  for (const char* object : {"sr_mode_control", "checkpoint", "actuator_limits"}) {
    if (!svc.require(svc.cap(object), object)) return 1;
  }
  auto requests = svc.advertise<rejuv_msg_SetpointUpdateRequest>("setpoint_update_request");
  if (!svc.require(requests, "setpoint_update_request")) return 1;

  SdkEffects effects(svc, *requests);
  services::SrManager manager(services::SrManagerConfig{.cycle = *cycle, .restricted = start->design.restricted},
                              start->design.ellipsoid, effects, start->x_sp);

  flight_io::FirstRefusalLog refuse(svc, "ignoring a message");
  auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state",
                                                             [&](const rejuv_msg_VehicleStateEstimate& m) {
                                                               if (auto ok = manager.on_state(m); !ok)
                                                                 refuse(ok.error());
                                                             });
  auto setpoint = svc.subscribe<rejuv_msg_Setpoint>("setpoint", [&](const rejuv_msg_Setpoint& m) {
    if (auto ok = manager.on_setpoint(m); !ok) refuse(ok.error());
  });
  auto rollback = svc.subscribe<rejuv_msg_RollbackSignal>(
      "rollback_signal", [&](const rejuv_msg_RollbackSignal& m) { manager.on_rollback_signal(m); });
  if (!svc.require_all("subscribe", state, setpoint, rollback)) return 1;
  // The check of (1) every check_period (§V-B: "after every 2 ms"); the handler ignores ticks outside a run.
  auto ticks = svc.every(to_nanos(cycle->tracking.check_period), [&] { manager.tick(); });
  if (!svc.require(ticks, "timer")) return 1;
  // The first cycle at the mission's t = 0, as the simulation boots (docs/design.md §6: SR starts with the flight; the
  // kernel passes the end of the plant's alignment on its clock). Never before the clock starts (every service
  // is Ready then).
  const auto flight_start = flight_io::read(params, graph_values::kFlightStart);
  if (!svc.require(flight_start, "bad params")) return 1;
  auto boot = svc.after(std::max(Nanos{1}, *flight_start - svc.now()), [&] { manager.start(); });
  if (!svc.require(boot, "timer")) return 1;
  return svc.run();
}

}  // namespace

int main() { return rejuv::services::run_service(serve, services::AttackHooks::Install); }
