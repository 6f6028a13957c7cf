// The graph-wide values of the SR scheme (§II, §IV-A, §V-B, docs/design.md §10): one table of every key the
// launch file's `sr` block sets and the kernel passes to every service as a boot param, and of the flight's start
// the kernel derives. Each key is a typed
// descriptor (Key<T>) with its name, the paper's symbol, its quantity and unit, the default a service uses when
// the kernel passes none, and its range. The launch loader checks a file's field against the key's range, the
// kernel sends with encode(key, value), a service reads with read(key, value), and the flight libraries take
// their defaults from here (docs/conventions.md "Ownership is visible": a configuration key is named once).
//
// On the wire (docs/protocol.md "Boot"), a duration crosses as integer nanoseconds, a switch and a count as an
// integer, every other quantity as a double in the unit its name carries.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::graph_values {

using namespace std::chrono_literals;

// What a key's value measures. The C++ type follows from it: Switch → bool, Duration → Nanos, Count →
// std::uint32_t, every other quantity → double in its unit.
enum class Quantity : std::uint8_t {
  Switch,
  Duration,      // s in the launch file, ns on the wire and in C++
  Fraction,      // dimensionless
  Count,
  Length,        // m
  Speed,         // m/s
  Angle,         // rad
  AngularRate,   // rad/s
  Acceleration,  // m/s²
};
// The unit as the launch file writes it ("s", "m", "m/s", "rad", "rad/s", "m/s²"; "" for the rest).
[[nodiscard]] std::string_view unit_of(Quantity quantity);

// A boot param's value as it crosses the kernel → service boundary: a double or an integer.
using Value = std::variant<double, std::int64_t>;

// The values a key accepts: min to max, each end open or closed. For a duration the bounds are ns.
template <class T>
struct Range {
  T min{};
  bool min_open = false;
  T max{};
  bool max_open = false;
};

// One graph-wide key. `name` is the launch file's field path and the boot param's name.
template <class T>
struct Key {
  std::string_view name;    // e.g. "sr.t_mc_s"
  std::string_view symbol;  // as the paper names it, e.g. "T_MC"
  Quantity quantity = Quantity::Fraction;
  T fallback{};             // what a service uses when the kernel passes no value
  Range<T> range{};
};

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// ---- the table ----
// Ranges: T_MC is of the order of 0.1–1 s in the paper (§VI; 0.3 s in launch/quad_square, 0.2–0.3 s in Fig. 11);
// beyond 10 s an unchecked worst-case attack of one window tilts the vehicle model out of the safety set many
// times over (docs/control.md §6), so 10 s bounds any meaningful design. T_est: 1–3 s in Fig. 11 (§VI-D), the
// safety controller brings x̂ back in ≈ 2.5 s (docs/control.md §6.1); 10 s bounds it the same way. t_min: a pause
// after a setpoint move (§V-C), shorter than one MC window: at most 1 s. The check of (1) runs at the control
// rate (2 ms, §V-B); slower than 0.1 s it overshoots ρ_s by a whole SC step, and below 1 µs the kernel's ns
// timers cannot keep it. ρ_M, ρ_s and Ū are fractions: of the safety set's level ‖e‖²_P ≤ 1 (§IV-A) and of the
// control range (§III). K generations: each holds a frozen process of every rejuvenated service (docs/design.md
// §7). The box half-widths scale P (docs/design.md §9); the estimator's re-arm 1σ are the EKF's (flight::EkfRearm).

inline constexpr Key<bool> kEnabled{"sr.enabled", "SR", Quantity::Switch, true, {false, false, true, false}};
inline constexpr Key<Nanos> kTmc{"sr.t_mc_s", "T_MC", Quantity::Duration, 300ms, {0ns, true, 10s, false}};
inline constexpr Key<Nanos> kTest{"sr.t_est_s", "T_est", Quantity::Duration, 3s, {0ns, true, 10s, false}};
inline constexpr Key<double> kRhoM{"sr.rho_m", "ρ_M", Quantity::Fraction, 0.1, {0.0, true, 1.0, false}};
inline constexpr Key<double> kRhoS{"sr.rho_s", "ρ_s", Quantity::Fraction, 0.0894, {0.0, true, 1.0, false}};
inline constexpr Key<Nanos> kTmin{"sr.t_min_s", "t_min", Quantity::Duration, 20ms, {0ns, false, 1s, false}};
inline constexpr Key<Nanos> kCheckPeriod{
    "sr.check_period_s", "check_period", Quantity::Duration, 2ms, {1us, false, 100ms, false}};
inline constexpr Key<std::uint32_t> kKeepGenerations{
    "sr.keep_generations", "K", Quantity::Count, 2, {1, false, 16, false}};
inline constexpr Key<double> kRestrictedLimitFraction{
    "sr.restricted_limit_fraction", "Ū", Quantity::Fraction, 0.003, {0.0, true, 1.0, false}};
inline constexpr Key<double> kBoxPosition{
    "sr.box.position_m", "position half-width", Quantity::Length, 1.0, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kBoxVelocity{
    "sr.box.velocity_m_s", "velocity half-width", Quantity::Speed, 1.5, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kBoxAngle{
    "sr.box.angle_rad", "angle half-width", Quantity::Angle, 0.5, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kBoxRate{
    "sr.box.rate_rad_s", "rate half-width", Quantity::AngularRate, 5.0, {0.0, true, kUnbounded, true}};
inline constexpr Key<bool> kRearmEnabled{
    "sr.ekf_rearm.enabled", "estimator re-armed after RB", Quantity::Switch, true, {false, false, true, false}};
inline constexpr Key<double> kRearmPositionStd{
    "sr.ekf_rearm.position_std_m", "σ_p", Quantity::Length, 0.1, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kRearmVelocityStd{
    "sr.ekf_rearm.velocity_std_m_s", "σ_v", Quantity::Speed, 0.2, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kRearmAttitudeStd{
    "sr.ekf_rearm.attitude_std_rad", "σ_θ", Quantity::Angle, 0.05, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kRearmGyroBiasStd{
    "sr.ekf_rearm.gyro_bias_std_rad_s", "σ_bg", Quantity::AngularRate, 0.002, {0.0, true, kUnbounded, true}};
inline constexpr Key<double> kRearmAccelBiasStd{
    "sr.ekf_rearm.accel_bias_std_m_s2", "σ_ba", Quantity::Acceleration, 0.02, {0.0, true, kUnbounded, true}};

// The mission's t = 0 on the kernel clock: the end of the plant's alignment, where SR starts (docs/design.md §6);
// 0 without a plant. Not a launch field: the kernel derives it. At most the launch loader's longest duration.
inline constexpr Key<Nanos> kFlightStart{
    "flight.start_s", "flight start", Quantity::Duration, 0ns, {0ns, false, 1'000'000s, false}};

// The estimator re-arm's 1σ keys, in idl/launch.proto EstimatorRearm's order.
inline constexpr std::array<const Key<double>*, 5> kRearmStds{&kRearmPositionStd, &kRearmVelocityStd,
                                                              &kRearmAttitudeStd, &kRearmGyroBiasStd,
                                                              &kRearmAccelBiasStd};
// The re-arm 1σ key whose name ends in `field` (an EstimatorRearm field, e.g. "position_std_m"); nullptr if none.
[[nodiscard]] const Key<double>* rearm_std(std::string_view field);

// Every key's name, for the tests that each is spelt once.
inline constexpr std::array<std::string_view, 20> kAllNames{
    kEnabled.name,          kTmc.name,          kTest.name,          kRhoM.name,         kRhoS.name,
    kTmin.name,             kCheckPeriod.name,  kKeepGenerations.name, kRestrictedLimitFraction.name,
    kBoxPosition.name,      kBoxVelocity.name,  kBoxAngle.name,      kBoxRate.name,      kRearmEnabled.name,
    kRearmPositionStd.name, kRearmVelocityStd.name, kRearmAttitudeStd.name, kRearmGyroBiasStd.name,
    kRearmAccelBiasStd.name, kFlightStart.name};

// The key's name less its "sr." prefix (and "box." / "ekf_rearm."): the field as the launch file's block writes it.
[[nodiscard]] std::string_view field_of(std::string_view name);

// ---- durations in the launch file ----
// A launch file's seconds as the nearest whole ns (the unit durations cross in).
[[nodiscard]] Nanos nanos_of_seconds(double seconds);

// ---- reading (a service) ----

// Why a boot param's value was refused.
struct ValueError {
  enum class Kind : std::uint8_t {
    WrongType,   // a double where a duration's integer ns is expected
    NotFinite,   // NaN or infinite
    OutOfRange,  // outside the key's range (or a switch other than 0/1, a count that is not whole)
  };
  Kind kind = Kind::OutOfRange;
  std::string key{};      // the key's name
  std::string message{};  // the range and the value, e.g. "expected 0 < T_MC ≤ 10 s, got 0 s"
  [[nodiscard]] std::string to_string() const { return key + ": " + message; }
};

// The typed value of `key` from `value` (nullopt: the kernel passed none → the key's fallback), checked against
// the key's range.
[[nodiscard]] Result<bool, ValueError> read(const Key<bool>& key, const std::optional<Value>& value);
[[nodiscard]] Result<Nanos, ValueError> read(const Key<Nanos>& key, const std::optional<Value>& value);
[[nodiscard]] Result<std::uint32_t, ValueError> read(const Key<std::uint32_t>& key,
                                                     const std::optional<Value>& value);
[[nodiscard]] Result<double, ValueError> read(const Key<double>& key, const std::optional<Value>& value);

// A switch as a number lookup gives it (a service's NumberLookup, sdk::Service::param): on when 1, the key's
// fallback when absent, off otherwise. For readers that only ask whether the scheme is on.
[[nodiscard]] bool is_on(const Key<bool>& key, std::optional<double> number);

// ---- sending (the kernel) ----
[[nodiscard]] Value encode(const Key<bool>& key, bool value);
[[nodiscard]] Value encode(const Key<Nanos>& key, Nanos value);
[[nodiscard]] Value encode(const Key<std::uint32_t>& key, std::uint32_t value);
[[nodiscard]] Value encode(const Key<double>& key, double value);

// ---- ranges (the launch loader, messages) ----
[[nodiscard]] bool in_range(const Key<Nanos>& key, Nanos value);
[[nodiscard]] bool in_range(const Key<std::uint32_t>& key, std::uint32_t value);
[[nodiscard]] bool in_range(const Key<double>& key, double value);
// The range as a reader sees it, in the file's unit: "0 < T_MC ≤ 10 s", "1 ≤ K ≤ 16", "ρ_M > 0".
[[nodiscard]] std::string range_text(const Key<Nanos>& key);
[[nodiscard]] std::string range_text(const Key<std::uint32_t>& key);
[[nodiscard]] std::string range_text(const Key<double>& key);

}  // namespace rejuv::graph_values
