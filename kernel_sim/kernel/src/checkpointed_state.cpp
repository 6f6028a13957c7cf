// The kernel state saved beside a generation's images, one value (image::CheckpointedState; docs/design.md §7 step 3):
// saved whole at a checkpoint's commit (checkpoint.cpp) and restored whole by a rollback (rollback.cpp).
#include "images.hpp"

namespace rejuv::kernel {

image::CheckpointedState save_state(Nanos t_cp, std::span<const image::Image> imaged,
                                    const std::vector<ServiceRuntime>& services, const broker::Broker& broker,
                                    const clock::TimerTable& timers) {
  image::CheckpointedState state{.t_cp = t_cp, .queues = {}, .services = {}};
  const std::vector<clock::KernelTimer> armed = timers.armed();
  for (const image::Image& im : imaged) {
    image::SavedService saved{.service = im.service, .subscriptions = services[im.service.value()].subscriptions,
                              .timers = {}};
    for (const clock::KernelTimer& t : armed) {
      if (t.service == im.service) saved.timers.push_back(t);
    }
    state.services.push_back(std::move(saved));
  }
  broker.snapshot_into(state.queues);
  return state;
}

Result<void, broker::BrokerError> restore_state(const image::CheckpointedState& state, Nanos now,
                                                std::vector<ServiceRuntime>& services, broker::Broker& broker,
                                                clock::TimerTable& timers) {
  if (auto restored = broker.restore(state.queues); !restored) return std::unexpected(restored.error());
  for (const image::SavedService& saved : state.services) {
    ServiceRuntime& s = services[saved.service.value()];
    s.subscriptions = saved.subscriptions;
    // docs/design.md §7 step 3: periodic timers realign to now (their phase within the period is kept), one-shot
    // timers shift by now − t_cp: both are the saved expiry moved by now − t_cp.
    for (const clock::KernelTimer& t : saved.timers) {
      (void)timers.arm(s.id, t.id, now + (t.due - state.t_cp), t.period);
    }
  }
  return {};
}

}  // namespace rejuv::kernel
