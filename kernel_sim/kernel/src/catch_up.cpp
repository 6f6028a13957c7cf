// The estimate catch-up's log and replay (catch_up.hpp).
#include "catch_up.hpp"

#include <algorithm>
#include <cstring>
#include <utility>

namespace rejuv::kernel {

CatchUp::CatchUp(Plan plan, std::size_t capacity, std::size_t slot_bytes)
    : plan_(std::move(plan)),
      capacity_(capacity),
      slot_bytes_(slot_bytes),
      entries_(capacity),
      arena_(capacity * slot_bytes) {
  REJUV_ASSERT(capacity > 0 && slot_bytes > 0, "a catch-up log holds something");
  cuts_.reserve(kCutsKept);
}

bool CatchUp::keep(ObjectId topic, std::span<const std::byte> bytes, std::uint64_t stamp) {
  REJUV_ASSERT(logs(topic) && bytes.size() <= slot_bytes_, "only the plan's topics are kept, each fits its slot");
  if (next_ - first_ == capacity_) {  // full: the oldest goes (a cut before it cannot be caught up to any more)
    ++first_;
    if (replaying_ && replay_ < first_) replay_ = first_;
    if (replaying_ && end_ < first_) end_ = first_;
  }
  const std::uint64_t seq = next_++;
  entries_[seq % capacity_] = Entry{.topic = topic.value(), .size = static_cast<std::uint32_t>(bytes.size()), .stamp = stamp};
  if (!bytes.empty()) std::memcpy(arena_.data() + (seq % capacity_) * slot_bytes_, bytes.data(), bytes.size());
  return replaying_;
}

void CatchUp::cut(Generation g) {
  if (!enabled()) return;
  if (cuts_.size() == kCutsKept) cuts_.erase(cuts_.begin());
  cuts_.push_back(Cut{.g = g, .seq = next_});
}

CatchUp::Begin CatchUp::begin(Generation g, Nanos wall) {
  if (!enabled()) return Begin::NothingToReplay;
  generation_ = g;
  replayed_to_ = 0;
  draining_ = false;
  const auto it = std::find_if(cuts_.begin(), cuts_.end(), [&](const Cut& c) { return c.g == g; });
  if (it == cuts_.end() || it->seq < first_) {
    ++stats_.without_log;
    replaying_ = false;
    return Begin::NoLog;
  }
  // The generations after g are erased by this rollback; g's own cut stays (the next rollback before a
  // checkpoint restores g again and replays from it again).
  cuts_.erase(std::next(it), cuts_.end());
  replay_ = it->seq;
  end_ = next_;
  replayed_ = 0;
  began_at_ = wall;
  replaying_ = replay_ != next_;
  if (!replaying_) return Begin::NothingToReplay;
  ++stats_.replays;
  return Begin::Replaying;
}

bool CatchUp::drops(ServiceId publisher, ObjectId topic) {
  if (!replaying_ || !flag(plan_.chain, publisher.value()) || !flag(plan_.cut_off, topic.value())) return false;
  ++stats_.dropped;
  return true;
}

void CatchUp::note_published(ServiceId publisher, ObjectId topic, std::span<const std::byte> bytes) {
  if (!flag(plan_.chain, publisher.value()) || !flag(plan_.estimate, topic.value())) return;
  rejuv_msg_VehicleStateEstimate m{};
  if (bytes.size() != sizeof m) return;
  std::memcpy(&m, bytes.data(), sizeof m);
  if ((m.flags & kEstimateCatchUpDiscarded) != 0) ++stats_.discarded;
}

void CatchUp::forget() {
  cuts_.clear();
  replaying_ = false;
  draining_ = false;
  replay_ = end_ = next_;
}

}  // namespace rejuv::kernel
