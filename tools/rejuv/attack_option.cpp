#include "attack_option.hpp"

#include <algorithm>
#include <filesystem>
#include <vector>

#include "rejuv/policy/audit.hpp"

namespace rejuv::cli {

Result<flight::AttackLaw, std::string> parse_attack_kind(std::string_view text) {
  if (const auto law = flight::attack_law_from_name_icase(text)) return *law;
  return fail("--attack: unknown attack kind '" + std::string(text) +
              "'; the kinds that act on the vehicle: " + flight::attack_law_names());
}

Result<void, std::string> override_attack(launch::LoadedLaunch& loaded, flight::AttackLaw law) {
  proto::AttackPlan& plan = *loaded.graph.mutable_attack();
  const auto kind = static_cast<proto::AttackKind>(flight::proto_number(law));
  const std::string service(flight::default_service(law));
  const proto::ServiceSpec* target = launch::find_service(loaded.graph, service);
  if (target == nullptr) {
    return fail("--attack " + std::string(flight::to_string(law)) + ": the graph " + loaded.graph.name() +
                " has no service \"" + service + "\" (the service this kind compromises)");
  }
  if (const auto hooks = launch::attack_hooks_of(target->executable());
      hooks && std::find(hooks->begin(), hooks->end(), kind) == hooks->end()) {
    return fail("--attack " + std::string(flight::to_string(law)) + ": service \"" + service + "\" (" +
                target->executable() + ") has no hook for it");
  }
  plan.set_enabled(true);
  proto::Attack& first = plan.attacks_size() > 0 ? *plan.mutable_attacks(0) : *plan.add_attacks();
  if (first.kind() != kind) first.set_magnitude(0.0);
  first.set_kind(kind);
  first.set_service(service);
  return {};
}

Result<launch::LoadedLaunch, std::string> load_with_attack(const std::string& path, std::optional<flight::AttackLaw> law,
                                                           std::string_view command) {
  return load_with_attack(std::span<const std::string>(&path, 1), law, command);
}

Result<launch::LoadedLaunch, std::string> load_with_attack(std::span<const std::string> paths,
                                                           std::optional<flight::AttackLaw> law, std::string_view command) {
  const std::vector<std::filesystem::path> files(paths.begin(), paths.end());
  auto loaded = launch::load_launch(std::span<const std::filesystem::path>(files));
  if (!loaded) return fail(loaded.error().to_string());
  // An object a service `uses` that its policy does not declare is an unknown name: refused here (exit 2), before
  // the kernel's audit would report it as a finding.
  const auto policy = policy::load_policy(loaded->policy_path, loaded->policy_includes);
  if (!policy) return fail(policy.error().to_string());
  if (auto ok = policy::check_used_objects(*policy, *loaded); !ok) return fail(ok.error().to_string());
  if (law) {
    if (auto ok = override_attack(*loaded, *law); !ok) return fail(std::string(command) + ": " + ok.error());
  }
  return std::move(*loaded);
}

std::string vehicle_attack_kind(const proto::Launch& graph) {
  if (!graph.attack().enabled()) return "";
  for (const proto::Attack& a : graph.attack().attacks()) {
    if (const auto law = flight::attack_law_from_number(a.kind())) return std::string(flight::to_string(*law));
  }
  return "";
}

}  // namespace rejuv::cli
