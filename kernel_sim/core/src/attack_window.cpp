#include "rejuv/core/attack_window.hpp"

#include <cmath>
#include <string>

#include "rejuv/core/graph_values.hpp"

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

Result<std::uint32_t, AttackParamError> whole_param(const NumberLookup& number, const std::string& name, double max) {
  const double v = number(name).value_or(0.0);
  if (!std::isfinite(v) || v < 0.0 || v > max || v != std::floor(v)) {
    return fail(AttackParamError{.param = name,
                                 .message = "expected a whole number in [0, " +
                                            std::to_string(static_cast<std::uint64_t>(max)) + "]"});
  }
  return static_cast<std::uint32_t>(v);
}

Result<BootAttackPlan, AttackParamError> boot_attack_plan(const NumberLookup& number, const TextLookup& text) {
  BootAttackPlan plan;
  plan.sr = graph_values::is_on(graph_values::kEnabled, number(graph_values::kEnabled.name)) ? Rejuvenation::On
                                                                                       : Rejuvenation::Off;
  plan.enabled = number("attack.enabled").value_or(0.0) == 1.0;
  if (!plan.enabled) return plan;
  auto count = whole_param(number, "attack.count", 64.0);
  if (!count) return fail(std::move(count.error()));
  for (std::uint32_t j = 0; j < *count; ++j) {
    BootAttack a;
    a.prefix = "attack." + std::to_string(j) + ".";
    a.kind = text(a.prefix + "kind");
    const double start = number(a.prefix + "start_s").value_or(0.0);
    if (!std::isfinite(start) || start < 0.0) {
      return fail(AttackParamError{.param = a.prefix + "start_s", .message = "expected a finite time >= 0 s"});
    }
    a.start = Seconds{start};
    auto windows = whole_param(number, a.prefix + "max_windows", 4294967295.0);
    if (!windows) return fail(std::move(windows.error()));
    a.max_windows = *windows;
    a.magnitude = number(a.prefix + "magnitude");
    plan.attacks.push_back(std::move(a));
  }
  return plan;
}

}  // namespace rejuv
