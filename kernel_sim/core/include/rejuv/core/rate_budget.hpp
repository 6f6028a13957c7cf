// A rate budget over a clock of the caller's (the kernel clock: simulated time in lockstep, CLOCK_MONOTONIC
// in real time): a token bucket that refills at `rate` units per second up to `burst` units. The kernel's
// per-service publication budget counts publications with it, the ULog recorder each topic's bytes
// (docs/sandbox.md "Floods cost only the flooder", docs/ulog.md "Size budget"). Integer arithmetic only, so
// that a lockstep run takes the same decisions for a seed.
#pragma once

#include <algorithm>
#include <cstdint>

#include "rejuv/core/time.hpp"

namespace rejuv {

class RateBudget {
 public:
  RateBudget() = default;
  // `per_second` units per second of the clock, at most `burst` ahead; full at the first take().
  RateBudget(std::uint64_t per_second, std::uint64_t burst)
      : per_second_(per_second), capacity_(burst * kScale), credit_(burst * kScale) {}

  // Whether `units` fit at `now` (taken if so). A clock that goes back (a rollback's epoch does not move the
  // kernel clock back, but a caller may) refills nothing.
  [[nodiscard]] bool take(Nanos now, std::uint64_t units = 1) {
    refill(now);
    const std::uint64_t cost = units * kScale;
    if (credit_ < cost) return false;
    credit_ -= cost;
    return true;
  }
  // Whether at least `fraction_percent` % of the burst is available at `now` (nothing taken).
  [[nodiscard]] bool refilled(Nanos now, std::uint64_t fraction_percent) {
    refill(now);
    return credit_ >= capacity_ / 100 * fraction_percent;
  }
  [[nodiscard]] std::uint64_t per_second() const { return per_second_; }

 private:
  // Credit in units × 10⁹ (unit-nanoseconds): `per_second` × elapsed ns adds exactly what elapsed.
  static constexpr std::uint64_t kScale = 1'000'000'000;
  void refill(Nanos now) {
    if (!started_) {
      started_ = true;
      last_ = now;
      return;
    }
    if (now <= last_) return;
    // At most one burst's worth of elapsed time counts: no overflow for any rate × any gap.
    const auto full_after = per_second_ == 0 ? std::uint64_t{0} : capacity_ / per_second_ + 1;
    const auto elapsed = std::min(static_cast<std::uint64_t>((now - last_).count()), full_after);
    credit_ = std::min(capacity_, credit_ + per_second_ * elapsed);
    last_ = now;
  }

  std::uint64_t per_second_ = 0;
  std::uint64_t capacity_ = 0;  // burst × kScale
  std::uint64_t credit_ = 0;
  Nanos last_{0};
  bool started_ = false;
};

}  // namespace rejuv
