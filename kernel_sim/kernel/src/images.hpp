// The Rejuvenator's internal header (docs/design.md §7; the overview is at the top of rejuvenator.cpp): what
// rejuvenator.cpp, checkpoint.cpp, rollback.cpp and checkpointed_state.cpp share.
#pragma once

#include <span>
#include <vector>

#include "impl.hpp"

namespace rejuv::kernel {

[[nodiscard]] inline double to_ms(Nanos d) { return static_cast<double>(d.count()) / 1e6; }
[[nodiscard]] inline unsigned long long num(Generation g) { return static_cast<unsigned long long>(g.value()); }

// The kernel state of a generation (docs/design.md §7 step 3), saved whole at the cut: t_cp, the broker's queue state
// and, for each service imaged, its subscriptions and armed timers. Reads the parts; changes nothing.
[[nodiscard]] image::CheckpointedState save_state(Nanos t_cp, std::span<const image::Image> imaged,
                                                  const std::vector<ServiceRuntime>& services,
                                                  const broker::Broker& broker, const clock::TimerTable& timers);

// Restores it whole at `now`: the queue state first (refused: nothing else changes), then each saved
// service's subscriptions and timers, moved by now − t_cp.
[[nodiscard]] Result<void, broker::BrokerError> restore_state(const image::CheckpointedState& state, Nanos now,
                                                              std::vector<ServiceRuntime>& services,
                                                              broker::Broker& broker, clock::TimerTable& timers);

}  // namespace rejuv::kernel
