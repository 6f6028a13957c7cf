// The kernel's end of the lockstep protocol with the plant (docs/design.md §6; the protocol: plant_topics.hpp,
// docs/protocol.md "Lockstep with the plant"), an adapter on the generic bridge (bridge.hpp). It owns what the
// protocol adds to the bridge: the SimStep reader and the SimStepAck writer; a count-only reader for each
// sample topic a step may overflow onto that the graph does not bridge in (what the plant publishes there
// counts toward SimStep.samples_published, bridged or not); which bridge input each sample a step carries is
// routed as; and the actuator outputs held for the step's ack. Which samples ride on a step is the table
// kStepSamples: nothing here names a sensor.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/dds/bridge.hpp"
#include "rejuv/dds/plant_topics.hpp"

namespace rejuv::dds {

class PlantLockstep {
 public:
  // What the kernel needs of a SimStep besides its samples.
  struct Step {
    std::uint64_t step = 0;
    Nanos t{0};                          // simulated time at the step's end
    std::uint64_t samples_needed = 0;    // SimStep.samples_published: samples on their own topics so far
  };

  // Adds the protocol's inputs to `bridge` (the count-only readers, then the SimStep reader last: the plant's
  // discovery sees them in that order) and creates the ack writer; every topic named as `naming` says
  // (plant_topics::dds_topic), as the plant names them.
  [[nodiscard]] static BridgeResult<PlantLockstep> open(Bridge& bridge, DdsNaming naming);

  [[nodiscard]] std::size_t step_input() const { return step_input_; }

  // Takes every SimStep that arrived: on_step(const Step&), then on_sample(input, bytes) for each sample it
  // carries whose topic the bridge routes in, as if that input had taken it (the same routes and canonical
  // order as a sample that came on its topic). Samples of a topic not bridged in are dropped, as the
  // count-only readers drop theirs.
  template <class OnStep, class OnSample>
  [[nodiscard]] DdsResult<std::size_t> take_steps(Bridge& bridge, OnStep&& on_step, OnSample&& on_sample);

  // Writes `payload` bridged out on `topic`. The actuator outputs are held for the step's ack instead (the
  // newest ones it holds; an older one that no longer fits goes out on its topic now, counted in
  // SimStepAck.outputs_published). False if the topic is not bridged out.
  [[nodiscard]] BridgeResult<bool> write_out(Bridge& bridge, ObjectId topic, std::span<const std::byte> payload);
  // Acknowledges a step (SimStepAck) with the held actuator outputs in it, and forgets them.
  [[nodiscard]] BridgeResult<void> write_ack(std::uint64_t step, Nanos t, Nanos charged);

 private:
  explicit PlantLockstep(Writer ack) : ack_(std::move(ack)) {}
  [[nodiscard]] BridgeResult<void> write_outputs(Bridge::Output& output, std::span<const std::byte> payload);

  Writer ack_;
  std::size_t step_input_ = 0;
  std::array<std::optional<std::size_t>, plant_topics::kStepSampleKinds> carried_input_{};  // by kStepSamples row
  std::optional<ObjectId> outputs_topic_{};  // the kernel topic bridged out as the plant's actuator outputs
  bool ack_matched_ = false;
  bool outputs_matched_ = false;
  std::uint64_t outputs_published_ = 0;
  rejuv_msg_SimStepAck held_{};  // outputs / outputs_count: the actuator outputs of the step in progress
};

template <class OnStep, class OnSample>
DdsResult<std::size_t> PlantLockstep::take_steps(Bridge& bridge, OnStep&& on_step, OnSample&& on_sample) {
  return bridge.inputs()[step_input_].reader.take_as<rejuv_msg_SimStep>([&](const rejuv_msg_SimStep& s) {
    on_step(Step{.step = s.step, .t = Nanos{static_cast<std::int64_t>(s.time_ns)}, .samples_needed = s.samples_published});
    plant_topics::for_each_step_kind([&](std::size_t row, const auto& kind) {
      if (!carried_input_[row]) return;
      for (const auto& sample : kind.samples(s)) on_sample(*carried_input_[row], std::as_bytes(std::span(&sample, 1)));
    });
  });
}

}  // namespace rejuv::dds
