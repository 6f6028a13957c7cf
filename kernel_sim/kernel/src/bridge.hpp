// The kernel's DDS component (docs/design.md §5): the generic bridge of the launch graph's `dds.bridges` table
// (rejuv/dds/bridge.hpp) and, in lockstep with a plant, the plant-lockstep adapter on it
// (rejuv/dds/plant_lockstep.hpp: the SimStep reader, the ack writer, the count-only sample readers and the
// actuator outputs held for the ack). The kernel's loop (loop.cpp, lockstep.cpp) takes the inputs; routing
// (router.cpp) writes through write_out.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/dds/bridge.hpp"
#include "rejuv/dds/plant_lockstep.hpp"

namespace rejuv::kernel {

class DdsBridge {
 public:
  // Every endpoint in `partition` (the run's: rejuv/dds/run_partition.hpp). `plant_lockstep`: also the adapter's
  // endpoints, named as `naming` says (the graph's dds.ros2_names, as the table's rows are).
  [[nodiscard]] static dds::BridgeResult<DdsBridge> open(std::uint32_t domain, std::string partition,
                                                         std::span<const dds::BridgeEntry> table, bool plant_lockstep,
                                                         DdsNaming naming, std::size_t object_count);

  // Every input: the table's (routed to their topic, in table order), then the adapter's (no topic).
  [[nodiscard]] std::vector<dds::Bridge::Input>& readers() { return bridge_.inputs(); }
  [[nodiscard]] bool is_step_input(std::size_t input) const { return plant_ && plant_->step_input() == input; }
  [[nodiscard]] dds::Bridge& bridge() { return bridge_; }
  // The adapter, in lockstep with a plant.
  [[nodiscard]] dds::PlantLockstep* lockstep() { return plant_ ? &*plant_ : nullptr; }

  // Writes `payload` if `topic` is bridged out (through the adapter in lockstep with a plant, which holds the
  // actuator outputs for the step's ack); false if it is not.
  [[nodiscard]] dds::BridgeResult<bool> write_out(ObjectId topic, std::span<const std::byte> payload);

 private:
  explicit DdsBridge(dds::Bridge bridge) : bridge_(std::move(bridge)) {}
  dds::Bridge bridge_;  // first: the adapter's endpoints live on its participant
  std::optional<dds::PlantLockstep> plant_;
};

}  // namespace rejuv::kernel
