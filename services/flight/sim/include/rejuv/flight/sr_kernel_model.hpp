// The trusted-kernel pieces of the SR scheme at the model level (docs/design.md §6–§8), as small value types the
// simulation engine composes: the rejuvenation timer (armed at most once per epoch), the image store (the last
// K checkpoint generations) and what checkpoint() returns (like fork: Taken in the live process, Restored in a
// resumed image). The multi-process runtime implements the same contracts with processes; this is the
// reference it is compared with.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::flight {

// What checkpoint() returns (docs/design.md §7 "Return value, not a semaphore").
struct CheckpointTaken {
  Generation generation;
};
struct CheckpointRestored {
  Generation generation;
  Epoch epoch;
};
using CheckpointReturn = std::variant<CheckpointTaken, CheckpointRestored>;

enum class TimerError : std::uint8_t {
  AlreadyArmedThisEpoch,  // docs/design.md §7: one arm per epoch; this removes the recursive do_timer of §V-C
  BadDuration,            // not positive and finite
};
[[nodiscard]] std::string to_string(TimerError error);

// The kernel's one-shot rejuvenation timer (do_timer(T_MC, 0) of §V-A). Expiry triggers a rollback.
class RejuvenationTimer {
 public:
  // Arms the timer to fire at now + after; refused if it was already armed in `epoch` (a restored image
  // resuming an old handler cannot arm it again, §V-C).
  [[nodiscard]] Result<void, TimerError> arm(Epoch epoch, Nanos now, Nanos after);
  // True once at the deadline; the timer is then disarmed (one-shot).
  [[nodiscard]] bool fire_if_due(Nanos now);
  [[nodiscard]] bool armed() const { return deadline_.has_value(); }
  [[nodiscard]] std::optional<Nanos> deadline() const { return deadline_; }
  [[nodiscard]] std::uint64_t refused() const { return refused_; }

 private:
  std::optional<Nanos> deadline_;
  std::optional<Epoch> armed_in_;
  std::uint64_t refused_ = 0;
};

// The last K generations of a copyable software image (docs/design.md §7: older images are dropped).
template <class Image>
class ImageStore {
 public:
  explicit ImageStore(std::size_t keep) : keep_(keep == 0 ? 1 : keep) {}

  Generation save(const Image& image, Nanos taken_at) {
    next_ = Generation{next_.value() + 1};
    if (images_.size() == keep_) images_.erase(images_.begin());  // K is small (2): a shift is cheaper than a deque
    images_.push_back(Entry{next_, taken_at, image});
    return next_;
  }
  struct Entry {
    Generation generation;
    Nanos taken_at{};
    Image image;
  };
  // The newest generation, if any.
  [[nodiscard]] const Entry* latest() const { return images_.empty() ? nullptr : images_.data() + (images_.size() - 1); }
  [[nodiscard]] std::size_t size() const { return images_.size(); }

 private:
  std::size_t keep_;
  Generation next_{0};
  std::vector<Entry> images_;
};

}  // namespace rejuv::flight
