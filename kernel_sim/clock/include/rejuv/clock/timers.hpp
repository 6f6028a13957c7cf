// Kernel timer objects (docs/design.md §6): services arm timers through their channel (wire::TimerSpec), the kernel
// fires them against its own clock — simulated time in lockstep, CLOCK_MONOTONIC in realtime. Because they
// are kernel objects they are part of the kernel state a checkpoint saves (docs/design.md §7 step 3: periodic
// timers realign to now, one-shot timers shift by now − t_cp after a rollback).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::clock {

inline constexpr std::size_t kMaxTimersPerService = 32;  // docs/protocol.md
inline constexpr Nanos kMinTimerPeriod{100'000};         // 100 µs: no timer storms

enum class TimerError : std::uint8_t {
  NoSuchService,   // the service id is outside the table
  TooManyTimers,   // kMaxTimersPerService live timers already
  BadPeriod,       // a periodic timer faster than kMinTimerPeriod, or a negative time
  NoSuchTimer,     // cancel of a timer that is not armed
};
[[nodiscard]] std::string_view to_string(TimerError error);

// One armed timer.
struct KernelTimer {
  ServiceId service{};
  std::uint64_t id = 0;  // the service's own id (re-arming an id replaces it)
  Nanos due{0};          // next expiry, kernel clock
  Nanos period{0};       // 0 = one-shot
  friend bool operator==(const KernelTimer&, const KernelTimer&) = default;
};

// Every timer of every service; fixed capacity, no allocation after construction.
class TimerTable {
 public:
  explicit TimerTable(std::size_t services);

  [[nodiscard]] Result<void, TimerError> arm(ServiceId service, std::uint64_t id, Nanos first, Nanos period);
  [[nodiscard]] Result<void, TimerError> cancel(ServiceId service, std::uint64_t id);
  // Drops every timer of a service (it died or was stopped); returns how many.
  std::size_t remove_service(ServiceId service);

  // Earliest expiry of any armed timer.
  [[nodiscard]] std::optional<Nanos> next_due() const;
  // Fires every timer due at or before `now`, ordered by (due, service, id) so that a lockstep run is
  // deterministic. A periodic timer that missed periods fires once and is re-armed at its first expiry
  // after `now` (the missed ones are counted in coalesced()); a one-shot timer is removed first, so
  // on_fire may re-arm it. Returns how many fired.
  template <class F>
  std::size_t fire_due(Nanos now, F&& on_fire);

  [[nodiscard]] std::size_t count(ServiceId service) const;
  [[nodiscard]] std::size_t total() const;
  [[nodiscard]] std::uint64_t coalesced() const { return coalesced_; }
  // Every armed timer, ordered by (service, id): the kernel-object state a checkpoint saves (§7).
  [[nodiscard]] std::vector<KernelTimer> armed() const;

 private:
  struct Entry {
    KernelTimer timer{};
    bool armed = false;
  };
  using Space = std::array<Entry, kMaxTimersPerService>;
  [[nodiscard]] Entry* find(ServiceId service, std::uint64_t id);
  void collect_due(Nanos now);

  std::vector<Space> spaces_;
  std::vector<KernelTimer> due_;  // scratch, capacity reserved at construction
  std::uint64_t coalesced_ = 0;
};

template <class F>
std::size_t TimerTable::fire_due(Nanos now, F&& on_fire) {
  collect_due(now);
  for (const KernelTimer& t : due_) {
    on_fire(t);
  }
  return due_.size();
}

}  // namespace rejuv::clock
