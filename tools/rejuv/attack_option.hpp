// `--attack KIND` of `rejuv run`, `rejuv sim` and `rejuv report table` (docs/control.md "Attack library"): the
// kind of the launch plan's first attack, by its idl/launch.proto AttackKind name (case-insensitive), one of
// the kinds that act on the vehicle (flight::AttackLaw). It replaces the first attack's kind and service (the
// kind's service in the reference graph, flight::default_service), keeps its start_s and max_windows, resets its
// magnitude to the kind's default when the kind changes, and turns the plan on. A graph without that service,
// or whose service has no hook for the kind (launch::attack_hooks_of), is refused as the loader refuses it.
#pragma once

#include <string>
#include <string_view>

#include "rejuv/core/result.hpp"
#include "rejuv/flight/attack_library.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {

inline constexpr const char* kAttackOptionHelp =
    "the kind of the plan's first attack (its service follows: e.g. ESTIMATE_SHIFT compromises ekf2):\n"
    "WORST_CASE_CONTROL, ESTIMATE_SHIFT, SENSOR_BIAS, SETPOINT_SHIFT, GAIN_OVERWRITE, ESTIMATE_DRIFT\n"
    "(case-insensitive; docs/control.md \"Attack library\")";

// The kind named by `text` (case-insensitive); the error lists the valid names.
[[nodiscard]] Result<flight::AttackLaw, std::string> parse_attack_kind(std::string_view text);
// Applies `law` to the loaded graph (header comment); the error names the graph and what is missing.
[[nodiscard]] Result<void, std::string> override_attack(launch::LoadedLaunch& loaded, flight::AttackLaw law);
// Both: the option's text applied to the graph.
[[nodiscard]] Result<void, std::string> apply_attack_option(launch::LoadedLaunch& loaded, std::string_view text);
// Adds `alignment` to the start_s of every attack of kinds 13–17 (kernel time = flight time + alignment).
void start_attack_library_after(proto::Launch& graph, Nanos alignment);
// The kind of the graph's attack that acts on the vehicle (the model's: the first such one), "" if none or off.
[[nodiscard]] std::string vehicle_attack_kind(const proto::Launch& graph);

}  // namespace rejuv::cli
