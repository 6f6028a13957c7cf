#include "rejuv/core/attack_window.hpp"

namespace rejuv {

namespace {
AttackWindowKind kind_of(SrMode mode) {
  return mode == SrMode::MC ? AttackWindowKind::MissionControl : AttackWindowKind::SecureInterval;
}
}  // namespace

bool AttackWindowClock::begins(Nanos now, SrMode mode, Epoch epoch) {
  const bool started = now >= schedule_.start;
  const AttackWindowKind here = kind_of(mode);
  if (schedule_.sr == Rejuvenation::Off) {
    if (here != AttackWindowKind::MissionControl || schedule_.window != here || !started) return false;
    if (attacked_without_sr_) return false;
    attacked_without_sr_ = true;
    ordinal_ = 0;
    return true;
  }
  const std::uint32_t e = epoch.value();
  if (here == AttackWindowKind::SecureInterval && started && !first_epoch_) first_epoch_ = e;
  if (schedule_.window != here || window_epoch_ == e) return false;
  window_epoch_ = e;
  if (!first_epoch_ || e < *first_epoch_) return false;
  const std::uint32_t n = e - *first_epoch_;
  if (schedule_.max_windows != 0 && n >= schedule_.max_windows) return false;
  ordinal_ = n;
  attacked_epoch_ = e;
  return true;
}

bool AttackWindowClock::open(SrMode mode, Epoch epoch) const {
  if (schedule_.sr == Rejuvenation::Off) return attacked_without_sr_;
  return attacked_epoch_ == epoch.value() && kind_of(mode) == schedule_.window;
}

}  // namespace rejuv
