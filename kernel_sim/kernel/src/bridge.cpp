#include "bridge.hpp"

namespace rejuv::kernel {

dds::BridgeResult<DdsBridge> DdsBridge::open(std::uint32_t domain, std::string partition,
                                             std::span<const dds::BridgeEntry> table, bool plant_lockstep,
                                             DdsNaming naming, std::size_t object_count) {
  auto bridge = dds::Bridge::open(dds::DomainId{domain}, std::move(partition), table, object_count);
  if (!bridge) return fail(bridge.error());
  DdsBridge b(std::move(*bridge));
  if (plant_lockstep) {
    auto plant = dds::PlantLockstep::open(b.bridge_, naming);
    if (!plant) return fail(plant.error());
    b.plant_ = std::move(*plant);
  }
  return b;
}

dds::BridgeResult<bool> DdsBridge::write_out(ObjectId topic, std::span<const std::byte> payload) {
  return plant_ ? plant_->write_out(bridge_, topic, payload) : bridge_.write_out(topic, payload);
}

}  // namespace rejuv::kernel
