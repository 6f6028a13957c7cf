// Fuzz target: the plant process's input (plant/app, docs/design.md §6, §9): the DDS samples it takes from the
// kernel — actuator_outputs and sim_step_ack, handed over as take_as does, a fixed-size struct copied from
// the sample's bytes — and the lockstep step they drive: the ack's charge bound and its outputs, the motor
// command held, PlantSim::advance and pack_step. Whatever the kernel sends, the plant must take no NaN
// into its motor command and never crash.
//
// Input: u64 seed (the world), then records: u8 kind (even: an ActuatorOutputs sample, odd: a SimStepAck),
// then the sample's bytes (sizeof the struct, zero-filled at the end of the input).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <iterator>
#include <vector>

#include "fuzz_input.hpp"
#include "rejuv/plant_app/plant_sim.hpp"

namespace {

// As plant/app/src/main.cpp: the lockstep step, and the most one ack may charge (longer: the plant exits).
constexpr rejuv::Nanos kStep{std::chrono::milliseconds{4}};
constexpr rejuv::Nanos kMaxChargePerStep{std::chrono::seconds{60}};
// A charge advances the world by that much more with the motors held: the same loop of physics ticks for
// any length, so the harness caps it to keep executions fast.
constexpr rejuv::Nanos kMaxFuzzCharge{std::chrono::milliseconds{50}};
constexpr int kMaxRecords = 32;

void check_command(const rejuv::plant_app::PlantSim& sim) {
  if (!sim.motor_command().allFinite()) std::abort();  // the plant takes no NaN from anyone (plant_sim.hpp)
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rejuv::fuzz::Input in(data, size);
  rejuv::plant_app::PlantSimConfig config;
  config.seed = in.value<std::uint64_t>();
  rejuv::plant_app::PlantSim sim(config);
  std::vector<rejuv::plant_app::SensorMessage> batch;
  std::vector<rejuv::plant_app::SensorMessage> overflow;
  rejuv::Nanos charged{0};
  for (int k = 0; k < kMaxRecords && !in.empty(); ++k) {
    if ((in.u8() & 1U) == 0) {
      (void)sim.set_motor_command(in.value<rejuv_msg_ActuatorOutputs>());
      check_command(sim);
      continue;
    }
    const auto ack = in.value<rejuv_msg_SimStepAck>();
    if (ack.charged_ns > static_cast<std::uint64_t>(kMaxChargePerStep.count())) return 0;  // the plant exits
    for (std::size_t i = 0; i < std::min<std::size_t>(ack.outputs_count, std::size(ack.outputs)); ++i) {
      (void)sim.set_motor_command(ack.outputs[i]);
      check_command(sim);
    }
    batch.clear();
    overflow.clear();
    sim.advance(kStep + charged, batch);
    rejuv_msg_SimStep step{};
    rejuv::plant_app::pack_step(batch, sim.ground_truth(), step, overflow);
    charged = std::min(rejuv::Nanos{static_cast<std::int64_t>(ack.charged_ns)}, kMaxFuzzCharge);
  }
  return 0;
}
