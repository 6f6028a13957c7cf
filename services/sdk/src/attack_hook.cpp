// The CUSTOM attack hook (rejuv/sdk/attack_hook.hpp): the plan from the boot params the kernel adds to every
// service (service.hpp "Params"), the windows by the one rule (rejuv/core/attack_window.hpp).
#include "rejuv/sdk/attack_hook.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "service_impl.hpp"

namespace rejuv::sdk {

CustomAttack::CustomAttack(Service& svc, std::vector<std::pair<AttackWindowClock, double>> clocks,
                           std::function<void(const AttackWindow&)> on_window)
    : svc_(svc), clocks_(std::move(clocks)), on_window_(std::move(on_window)), current_(clocks_.size()) {}

SdkResult<std::unique_ptr<CustomAttack>> CustomAttack::install(
    Service& svc, std::function<void(const AttackWindow&)> on_window) {
  auto plan = boot_attack_plan(
      [&svc](std::string_view name) -> std::optional<double> {
        if (!svc.has_param(name)) return std::nullopt;
        return svc.param(name, 0.0);
      },
      [&svc](std::string_view name) { return std::string(svc.text_param(name, "")); });
  if (!plan) return error(SdkError::BadArgument, plan.error().to_string());
  std::vector<std::pair<AttackWindowClock, double>> clocks;
  std::string described;
  for (const BootAttack& a : plan->attacks) {
    if (a.kind != "CUSTOM") continue;
    // The magnitude is the author's to interpret; a finite number in [0, 1e6] (absent = 0).
    const double magnitude = a.magnitude.value_or(0.0);
    if (!std::isfinite(magnitude) || magnitude < 0.0 || magnitude > 1e6) {
      return error(SdkError::BadArgument, a.prefix + "magnitude: expected a number in [0, 1e6], got " +
                                               std::to_string(magnitude));
    }
    // start is kernel time: the kernel adds the pre-flight alignment (no window before take-off).
    clocks.emplace_back(AttackWindowClock(AttackSchedule{.start = to_nanos(a.start),
                                                         .max_windows = a.max_windows,
                                                         .window = AttackWindowKind::MissionControl,
                                                         .sr = plan->sr}),
                        magnitude);
    char line[160];
    std::snprintf(line, sizeof line, "%sCUSTOM from t = %.3f s (kernel time), %s, magnitude %g",
                  described.empty() ? "" : "; ", a.start.count(),
                  a.max_windows == 0 ? "every MC window" : (std::to_string(a.max_windows) + " MC window(s)").c_str(),
                  magnitude);
    described += line;
  }
  if (clocks.empty()) return std::unique_ptr<CustomAttack>{};
  auto hook = std::make_unique<CustomAttack>(svc, std::move(clocks), std::move(on_window));
  CustomAttack* raw = hook.get();
  auto timer = svc.every(kTick, [raw] { raw->tick(); });
  if (!timer) return std::unexpected(timer.error());
  svc.logf(LogLevel::Warn, "attack hook armed: %s", described.c_str());
  return hook;
}

void CustomAttack::tick() {
  const Nanos now = svc_.now();
  const SrMode mode = svc_.mode();
  const Epoch epoch = svc_.epoch();
  for (std::size_t i = 0; i < clocks_.size(); ++i) {
    AttackWindowClock& clock = clocks_[i].first;
    if (!clock.begins(now, mode, epoch)) continue;
    current_[i] = AttackWindow{.attack = static_cast<std::uint32_t>(i),
                               .ordinal = clock.ordinal(),
                               .epoch = epoch,
                               .began = now,
                               .magnitude = clocks_[i].second};
    ++windows_;
    if (on_window_) on_window_(*current_[i]);
  }
}

std::optional<AttackWindow> CustomAttack::window() {
  tick();
  const SrMode mode = svc_.mode();
  const Epoch epoch = svc_.epoch();
  for (std::size_t i = 0; i < clocks_.size(); ++i) {
    if (current_[i] && clocks_[i].first.open(mode, epoch)) return current_[i];
  }
  return std::nullopt;
}

}  // namespace rejuv::sdk
