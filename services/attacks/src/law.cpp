#include "rejuv/attacks/law.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "rejuv/core/graph_values.hpp"

namespace rejuv::attacks {

Result<std::optional<LawAttack>, PlanError> law_attack_plan(const NumberLookup& number, const TextLookup& text,
                                                            std::initializer_list<flight::AttackLaw> laws) {
  if (number("attack.enabled").value_or(0.0) != 1.0) return std::optional<LawAttack>{};
  const double count = number("attack.count").value_or(0.0);
  if (!std::isfinite(count) || count < 0.0 || count > 64.0 || count != std::floor(count)) {
    return fail(PlanError{.param = "attack.count", .message = "expected a whole number in [0, 64]"});
  }
  const Rejuvenation sr = graph_values::is_on(graph_values::kEnabled, number(graph_values::kEnabled.name))
                               ? Rejuvenation::On
                               : Rejuvenation::Off;
  for (int j = 0; j < static_cast<int>(count); ++j) {
    const std::string prefix = "attack." + std::to_string(j) + ".";
    const auto law = flight::attack_law_from_name(text(prefix + "kind"));
    if (!law || std::find(laws.begin(), laws.end(), *law) == laws.end()) continue;
    const double start = number(prefix + "start_s").value_or(0.0);
    if (!std::isfinite(start) || start < 0.0) {
      return fail(PlanError{.param = prefix + "start_s", .message = "expected a finite time >= 0 s"});
    }
    const double windows = number(prefix + "max_windows").value_or(0.0);
    if (!std::isfinite(windows) || windows < 0.0 || windows > 4294967295.0 || windows != std::floor(windows)) {
      return fail(PlanError{.param = prefix + "max_windows", .message = "expected a whole number >= 0"});
    }
    const double magnitude = number(prefix + "magnitude").value_or(0.0);
    if (!std::isfinite(magnitude) || magnitude < 0.0) {
      return fail(PlanError{.param = prefix + "magnitude", .message = "expected a finite size >= 0"});
    }
    return std::optional<LawAttack>{LawAttack{.law = *law,
                                              .start = Seconds{start},
                                              .max_windows = static_cast<std::uint32_t>(windows),
                                              .magnitude = flight::effective_magnitude(*law, magnitude),
                                              .sr = sr}};
  }
  return std::optional<LawAttack>{};
}

namespace {
// The window clock of plan.hpp counts MC windows for any MC-window kind; the law's own kind is not in its enum.
RuntimeAttack as_windowed(const LawAttack& a) {
  return RuntimeAttack{.kind = AttackKind::ForgedSlot, .start = a.start, .max_windows = a.max_windows};
}
}  // namespace

LawWindow::LawWindow(const LawAttack& attack) : attack_(attack), clock_(as_windowed(attack), attack.sr) {}

std::optional<Seconds> LawWindow::tau(Nanos now, SrMode mode, Epoch epoch) {
  began_now_ = clock_.begins(now, mode, epoch);
  if (began_now_) {
    active_epoch_ = epoch;
    began_ = now;
  }
  if (!active_epoch_) return std::nullopt;
  // Without SR the one MC window never ends; with SR the window of the attacked epoch ends with MC (and the
  // rollback that follows erases everything this process did in it).
  if (attack_.sr == Rejuvenation::On && (mode != SrMode::MC || *active_epoch_ != epoch)) return std::nullopt;
  return to_seconds(now - began_);
}

}  // namespace rejuv::attacks
