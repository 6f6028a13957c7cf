#include "rejuv/services/lqr_control/worst_case_attack.hpp"

#if defined(REJUV_ATTACK_HOOKS)

#include <cmath>
#include <utility>

#include "rejuv/flight/attack.hpp"

namespace rejuv::services {

namespace {

flight_io::InputFailure bad(flight_io::InputError kind, std::string where, std::string message) {
  return flight_io::InputFailure{.kind = kind, .where = std::move(where), .message = std::move(message)};
}

// A whole number in [0, max] (count, max_windows).
Result<std::uint32_t, flight_io::InputFailure> whole(const flight_io::Params& p, const std::string& name,
                                                     double max) {
  const double v = p.find(name).value_or(0.0);
  if (!std::isfinite(v)) return fail(bad(flight_io::InputError::NotFinite, name, "expected a whole number"));
  if (v < 0.0 || v > max || v != std::floor(v)) {
    return fail(bad(flight_io::InputError::OutOfRange, name, "expected a whole number >= 0"));
  }
  return static_cast<std::uint32_t>(v);
}

}  // namespace

Result<std::optional<WorstCaseAttackPlan>, flight_io::InputFailure> worst_case_attack_plan(
    const flight_io::Params& numbers, const TextParam& text) {
  if (numbers.find("attack.enabled").value_or(0.0) != 1.0) return std::optional<WorstCaseAttackPlan>{};
  auto count = whole(numbers, "attack.count", 64.0);
  if (!count) return fail(std::move(count.error()));
  const bool sr_on = graph_values::is_on(graph_values::kEnabled, numbers.find(graph_values::kEnabled.name));
  for (std::uint32_t j = 0; j < *count; ++j) {
    const std::string prefix = "attack." + std::to_string(j) + ".";
    if (text(prefix + "kind") != "WORST_CASE_CONTROL") continue;
    const double start = numbers.find(prefix + "start_s").value_or(0.0);
    if (!std::isfinite(start) || start < 0.0) {
      return fail(
          bad(flight_io::InputError::OutOfRange, prefix + "start_s", "expected a finite time >= 0 s"));
    }
    auto windows = whole(numbers, prefix + "max_windows", 4294967295.0);
    if (!windows) return fail(std::move(windows.error()));
    return std::optional<WorstCaseAttackPlan>{
        WorstCaseAttackPlan{.start = Seconds{start},
                            .max_windows = *windows,
                            .sr = sr_on ? flight::SrSwitch::On : flight::SrSwitch::Off}};
  }
  return std::optional<WorstCaseAttackPlan>{};
}

WorstCaseAttack::WorstCaseAttack(const WorstCaseAttackPlan& plan, const flight::ControlDesign& design)
    : plan_(plan), restricted_(design.restricted), P_(design.ellipsoid.P()), B_(design.continuous.B) {}

bool WorstCaseAttack::decide(Nanos now, SrMode mode, Epoch epoch) {
  const bool started = now >= to_nanos(plan_.start);
  if (plan_.sr == flight::SrSwitch::Off) {
    // The simulation without SR: one endless MC window, attacked from `start` on.
    if (mode != SrMode::MC || !started) return false;
    if (windows_attacked_ == 0) windows_attacked_ = 1;
    return true;
  }
  if (mode != SrMode::MC) {
    // The SEI: remember (into the next checkpoint) the first epoch whose windows may be attacked.
    if (started && !first_epoch_) first_epoch_ = epoch;
    return false;
  }
  if (window_epoch_ != epoch) {
    // The start of the MC window of this epoch: decided once for the whole window (begin_mc_window).
    window_epoch_ = epoch;
    window_attacked_ = first_epoch_.has_value() && epoch.value() >= first_epoch_->value() &&
                       (plan_.max_windows == 0 || epoch.value() - first_epoch_->value() < plan_.max_windows);
    if (window_attacked_) ++windows_attacked_;
  }
  return window_attacked_;
}

flight::InputVec WorstCaseAttack::corner(const flight::StateVec& x_hat, const flight::StateVec& x_sp) const {
  return flight::worst_case_corner(restricted_, P_, B_, flight::state_error(x_hat, x_sp));
}

std::optional<flight::InputVec> WorstCaseAttack::on_control(Nanos now, SrMode mode, Epoch epoch,
                                                            const flight::StateVec& x_hat,
                                                            const flight::StateVec& x_sp) {
  if (!decide(now, mode, epoch)) return std::nullopt;
  return corner(x_hat, x_sp);
}

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
