// Routing frozen while a checkpoint or a rollback is timed (docs/design.md §7): publications land in the broker's
// rings undelivered (router.cpp: deliver_one, hand_over_polled) and the kernel's DDS bridge writes are held —
// a woken service or plant thread would take the CPU at once. When routing resumes (rejuvenator.cpp,
// resume_routing) the held writes go out in the order they were published, then the rings are swept.
#pragma once

#include <span>
#include <utility>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"

namespace rejuv::kernel {

class RoutingFreeze {
 public:
  void freeze() { frozen_ = true; }
  [[nodiscard]] bool frozen() const { return frozen_; }
  // A bridge write while frozen, kept for thaw.
  void hold(ObjectId topic, std::span<const std::byte> payload) {
    REJUV_ASSERT(frozen_, "writes are held only while routing is frozen");
    held_.emplace_back(topic, std::vector<std::byte>(payload.begin(), payload.end()));
  }
  // Routing resumes: write(topic, payload) for each held write in order, until one returns false (the run
  // stops; the rest are dropped).
  template <typename Write>
  void thaw(Write&& write) {
    frozen_ = false;
    for (const auto& [topic, payload] : held_) {
      if (!write(topic, std::span<const std::byte>(payload))) break;
    }
    held_.clear();
  }

 private:
  bool frozen_ = false;
  std::vector<std::pair<ObjectId, std::vector<std::byte>>> held_;
};

}  // namespace rejuv::kernel
