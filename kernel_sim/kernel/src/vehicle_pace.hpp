// When in the vehicle's control period image work disturbs it least (docs/realtime.md "Image work in the
// slack"). In real time with a plant the control chain runs once per sample (sensors → ekf2 →
// controllers → output_driver) and is idle for most of the period after its actuator output. A checkpoint
// (≈ 1 ms timed) that starts just before a sample arrives holds that sample's update back by its whole
// duration; one that starts just after an update ends long before the next sample. So:
//   - a checkpoint starts in the first half of a period (measured from the last control update), or waits for
//     the next update — at most kMaxWaitPeriods periods, then it starts anyway (a chain that has stopped
//     updating must not stop the SR cycle);
//   - a rejuvenation timer due before the next update is expected fires in the slack after this one: up to one
//     period EARLY, never late. An earlier rollback only shortens the attacker's window (§V-B: the MC window is
//     an upper bound); a later one would lengthen it.
// The period is the median of the last kWindow intervals between control updates, so one late update does
// not move it. Lockstep stops the world while the kernel works and never asks (enabled = false): its runs stay
// deterministic. One owner: the image coordinator (rejuvenator.cpp); the routing core feeds it the updates
// (watch.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <optional>

#include "rejuv/core/time.hpp"

namespace rejuv::kernel {

class VehiclePace {
 public:
  static constexpr std::size_t kWindow = 8;
  static constexpr int kMaxWaitPeriods = 2;
  static constexpr Nanos kMinPeriod{std::chrono::microseconds{500}};
  static constexpr Nanos kMaxPeriod{std::chrono::milliseconds{100}};

  VehiclePace() = default;
  explicit VehiclePace(bool enabled) : enabled_(enabled) {}

  [[nodiscard]] bool enabled() const { return enabled_; }

  // An actuator output was routed at `wall` (monotonic wall clock).
  void on_control_update(Nanos wall) {
    if (!enabled_) return;
    if (last_) {
      const Nanos interval = wall - *last_;
      // Intervals outside [kMinPeriod, kMaxPeriod] (two updates of one sample, a stall) say nothing of the period.
      if (interval >= kMinPeriod && interval <= kMaxPeriod) {
        intervals_[next_ % kWindow] = interval;
        ++next_;
      }
    }
    last_ = wall;
  }

  // The control period: the median of the last kWindow intervals, once three were seen.
  [[nodiscard]] std::optional<Nanos> period() const {
    const std::size_t n = std::min(next_, kWindow);
    if (n < 3) return std::nullopt;
    std::array<Nanos, kWindow> sorted = intervals_;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(n / 2), sorted.begin() + static_cast<std::ptrdiff_t>(n));
    return sorted[n / 2];
  }

  // Whether `now` lies in the first half of a period after the last control update: work of up to half a
  // period started now ends before the next sample's update is due. Without a pace (lockstep, no plant, no
  // period yet): always.
  [[nodiscard]] bool in_slack(Nanos now) const {
    const auto p = period();
    if (!enabled_ || !p || !last_) return true;
    const Nanos since = now - *last_;
    return since >= Nanos{0} && since <= *p / 2;
  }

  // A checkpoint that was asked for: may it start at `now`? In the slack, or once it has waited
  // kMaxWaitPeriods periods since it was first asked about (waiting_since). started() ends the wait.
  [[nodiscard]] bool may_start(Nanos now) {
    if (in_slack(now)) return true;
    if (!waiting_since_) waiting_since_ = now;
    return now >= *waiting_since_ + kMaxWaitPeriods * *period();
  }
  void started() { waiting_since_.reset(); }
  // When a waiting checkpoint starts regardless (for the loop's wall deadline), if one waits.
  [[nodiscard]] std::optional<Nanos> wait_deadline() const {
    if (!waiting_since_) return std::nullopt;
    return *waiting_since_ + kMaxWaitPeriods * period().value_or(Nanos{0});
  }

  // Whether a rejuvenation timer due `until_due` (simulated time) from now should fire at `now` (wall): in
  // the slack, and due before the next update is expected. Never for a timer already due (it fires anyway).
  [[nodiscard]] bool fire_early(Nanos now, Nanos until_due) const {
    const auto p = period();
    if (!enabled_ || !p || !last_ || until_due <= Nanos{0}) return false;
    return in_slack(now) && until_due < *last_ + *p - now;
  }

 private:
  bool enabled_ = false;
  std::optional<Nanos> last_{};
  std::array<Nanos, kWindow> intervals_{};
  std::size_t next_ = 0;  // intervals recorded so far (the ring's next index, mod kWindow)
  std::optional<Nanos> waiting_since_{};
};

}  // namespace rejuv::kernel
