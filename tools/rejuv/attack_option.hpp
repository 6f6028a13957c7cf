// `--attack KIND` (declared in common_options.hpp) of `rejuv run`, `rejuv sim` and `rejuv report table` (docs/control.md "Attack library"): the
// kind of the launch plan's first attack, by its idl/launch.proto AttackKind name (case-insensitive), one of
// the kinds that act on the vehicle (flight::AttackLaw). It replaces the first attack's kind and service (the
// kind's service in the reference graph, flight::default_service), keeps its start_s and max_windows, resets its
// magnitude to the kind's default when the kind changes, and turns the plan on. A graph without that service,
// or whose service has no hook for the kind (launch::attack_hooks_of), is refused as the loader refuses it.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "rejuv/core/result.hpp"
#include "rejuv/flight/attack_library.hpp"
#include "rejuv/launch/launch.hpp"

namespace rejuv::cli {

// The kind named by `text` (case-insensitive); the error lists the valid names.
[[nodiscard]] Result<flight::AttackLaw, std::string> parse_attack_kind(std::string_view text);
// Applies `law` to the loaded graph (header comment); the error names the graph and what is missing.
[[nodiscard]] Result<void, std::string> override_attack(launch::LoadedLaunch& loaded, flight::AttackLaw law);
// The launch graph at `path` with `law` applied when given (run, sim, report): the error is the loader's
// (file:line:column) or "<command>: --attack …".
[[nodiscard]] Result<launch::LoadedLaunch, std::string> load_with_attack(const std::string& path,
                                                                       std::optional<flight::AttackLaw> law,
                                                                       std::string_view command);
// The same for several launch files composed into one graph (launch::load_launch of several paths).
[[nodiscard]] Result<launch::LoadedLaunch, std::string> load_with_attack(std::span<const std::string> paths,
                                                                       std::optional<flight::AttackLaw> law,
                                                                       std::string_view command);
// The kind of the graph's attack that acts on the vehicle (the model's: the first such one), "" if none or off.
[[nodiscard]] std::string vehicle_attack_kind(const proto::Launch& graph);

}  // namespace rejuv::cli
