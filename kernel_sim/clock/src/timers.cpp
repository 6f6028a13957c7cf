#include "rejuv/clock/timers.hpp"

#include <tuple>

namespace rejuv::clock {

std::string_view to_string(TimerError error) {
  switch (error) {
    case TimerError::NoSuchService: return "NoSuchService";
    case TimerError::TooManyTimers: return "TooManyTimers";
    case TimerError::BadPeriod: return "BadPeriod";
    case TimerError::NoSuchTimer: return "NoSuchTimer";
  }
  return "?";
}

TimerTable::TimerTable(std::size_t services) : spaces_(services) {
  due_.reserve(services * kMaxTimersPerService);
}

TimerTable::Entry* TimerTable::find(ServiceId service, std::uint64_t id) {
  for (Entry& e : spaces_[service.value()]) {
    if (e.armed && e.timer.id == id) return &e;
  }
  return nullptr;
}

Result<void, TimerError> TimerTable::arm(ServiceId service, std::uint64_t id, Nanos first, Nanos period) {
  if (service.value() >= spaces_.size()) return fail(TimerError::NoSuchService);
  if (first.count() < 0 || period.count() < 0 || (period.count() > 0 && period < kMinTimerPeriod)) {
    return fail(TimerError::BadPeriod);
  }
  Entry* slot = find(service, id);
  if (slot == nullptr) {
    for (Entry& e : spaces_[service.value()]) {
      if (!e.armed) {
        slot = &e;
        break;
      }
    }
  }
  if (slot == nullptr) return fail(TimerError::TooManyTimers);
  slot->armed = true;
  slot->timer = KernelTimer{.service = service, .id = id, .due = first, .period = period};
  return {};
}

Result<void, TimerError> TimerTable::cancel(ServiceId service, std::uint64_t id) {
  if (service.value() >= spaces_.size()) return fail(TimerError::NoSuchService);
  Entry* e = find(service, id);
  if (e == nullptr) return fail(TimerError::NoSuchTimer);
  e->armed = false;
  return {};
}

std::size_t TimerTable::remove_service(ServiceId service) {
  if (service.value() >= spaces_.size()) return 0;
  std::size_t n = 0;
  for (Entry& e : spaces_[service.value()]) {
    n += e.armed ? 1 : 0;
    e.armed = false;
  }
  return n;
}

std::optional<Nanos> TimerTable::next_due() const {
  std::optional<Nanos> best;
  for (const Space& s : spaces_) {
    for (const Entry& e : s) {
      if (e.armed && (!best || e.timer.due < *best)) best = e.timer.due;
    }
  }
  return best;
}

void TimerTable::collect_due(Nanos now) {
  due_.clear();
  for (Space& s : spaces_) {
    for (Entry& e : s) {
      if (!e.armed || e.timer.due > now) continue;
      due_.push_back(e.timer);
      if (e.timer.period.count() == 0) {
        e.armed = false;
      } else {
        const auto missed = (now - e.timer.due) / e.timer.period;  // whole periods skipped
        coalesced_ += static_cast<std::uint64_t>(missed);
        e.timer.due += e.timer.period * (missed + 1);
      }
    }
  }
  std::sort(due_.begin(), due_.end(), [](const KernelTimer& a, const KernelTimer& b) {
    return std::tuple(a.due, a.service, a.id) < std::tuple(b.due, b.service, b.id);
  });
}

std::size_t TimerTable::count(ServiceId service) const {
  if (service.value() >= spaces_.size()) return 0;
  return static_cast<std::size_t>(std::count_if(spaces_[service.value()].begin(), spaces_[service.value()].end(),
                                                [](const Entry& e) { return e.armed; }));
}

std::size_t TimerTable::total() const {
  std::size_t n = 0;
  for (std::size_t s = 0; s < spaces_.size(); ++s) n += count(ServiceId(static_cast<std::uint32_t>(s)));
  return n;
}

std::vector<KernelTimer> TimerTable::armed() const {
  std::vector<KernelTimer> out;
  for (const Space& s : spaces_) {
    for (const Entry& e : s) {
      if (e.armed) out.push_back(e.timer);
    }
  }
  std::sort(out.begin(), out.end(), [](const KernelTimer& a, const KernelTimer& b) {
    return std::tuple(a.service, a.id) < std::tuple(b.service, b.id);
  });
  return out;
}

}  // namespace rejuv::clock
