// The CUSTOM attack hook (rejuv/sdk/attack_hook.hpp): the plan from the boot params the kernel adds to every
// service (service.hpp "Params"), the windows by the one rule (rejuv/core/attack_window.hpp).
#include "rejuv/sdk/attack_hook.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "service_impl.hpp"

namespace rejuv::sdk {

namespace {

// A number param that must be finite, >= 0 and at most `max` (and whole when `whole`); absent = 0.
SdkResult<double> checked(const Service& svc, const std::string& name, double max, bool whole) {
  const double v = svc.param(name, 0.0);
  if (!std::isfinite(v) || v < 0.0 || v > max || (whole && v != std::floor(v))) {
    return error(SdkError::BadArgument, name + ": expected " + (whole ? "a whole number" : "a number") +
                                            " in [0, " + std::to_string(max) + "], got " + std::to_string(v));
  }
  return v;
}

}  // namespace

CustomAttack::CustomAttack(Service& svc, std::vector<std::pair<AttackWindowClock, double>> clocks,
                           std::function<void(const AttackWindow&)> on_window)
    : svc_(svc), clocks_(std::move(clocks)), on_window_(std::move(on_window)), current_(clocks_.size()) {}

SdkResult<std::unique_ptr<CustomAttack>> CustomAttack::install(
    Service& svc, std::function<void(const AttackWindow&)> on_window) {
  if (svc.param("attack.enabled", 0.0) != 1.0) return std::unique_ptr<CustomAttack>{};
  auto count = checked(svc, "attack.count", 64.0, true);
  if (!count) return std::unexpected(count.error());
  const Rejuvenation sr = svc.param("sr.enabled", 1.0) == 1.0 ? Rejuvenation::On : Rejuvenation::Off;
  std::vector<std::pair<AttackWindowClock, double>> clocks;
  std::string described;
  for (int j = 0; j < static_cast<int>(*count); ++j) {
    const std::string prefix = "attack." + std::to_string(j) + ".";
    if (svc.text_param(prefix + "kind", "") != "CUSTOM") continue;
    // start_s is kernel time: the kernel adds the pre-flight alignment (no window before take-off).
    auto start = checked(svc, prefix + "start_s", 1e9, false);
    if (!start) return std::unexpected(start.error());
    auto windows = checked(svc, prefix + "max_windows", 4294967295.0, true);
    if (!windows) return std::unexpected(windows.error());
    auto magnitude = checked(svc, prefix + "magnitude", 1e6, false);
    if (!magnitude) return std::unexpected(magnitude.error());
    clocks.emplace_back(AttackWindowClock(AttackSchedule{.start = to_nanos(Seconds{*start}),
                                                         .max_windows = static_cast<std::uint32_t>(*windows),
                                                         .window = AttackWindowKind::MissionControl,
                                                         .sr = sr}),
                        *magnitude);
    char line[160];
    std::snprintf(line, sizeof line, "%sCUSTOM from t = %.3f s (kernel time), %s, magnitude %g",
                  described.empty() ? "" : "; ", *start,
                  *windows == 0
                      ? "every MC window"
                      : (std::to_string(static_cast<std::uint64_t>(*windows)) + " MC window(s)").c_str(),
                  *magnitude);
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
