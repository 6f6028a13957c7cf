// Fuzz target: the launch loader and the audit of a policy against the graph (kernel_sim/launch,
// kernel_sim/policy, docs/design.md §4). Text → parse_launch (as if it were launch/fuzz.launch.pbtxt, so that the
// repository's policies resolve) → the policy it names → audit(policy, graph) and the graph-derived values
// the kernel reads. Bad text must give a LoadError with a location, never a crash or an abort.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/policy.hpp"

namespace {

const std::filesystem::path& as_path() {
  static const std::filesystem::path p = std::filesystem::path(REJUV_SOURCE_DIR) / "launch" / "fuzz.launch.pbtxt";
  return p;
}

// Policies by path, loaded once: the fuzzer mutates the graph, not the repository's files. A graph may name
// any existing file; past a few paths the rest are not kept.
const rejuv::policy::Policy* policy_at(const std::filesystem::path& path) {
  static std::map<std::string, std::optional<rejuv::policy::Policy>> cache;
  if (cache.size() >= 32 && !cache.contains(path.string())) cache.clear();
  auto [it, fresh] = cache.try_emplace(path.string());
  if (fresh) {
    auto loaded = rejuv::policy::load_policy(path);
    if (loaded) it->second.emplace(std::move(*loaded));
  }
  return it->second ? &*it->second : nullptr;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto graph = rejuv::launch::parse_launch(text, as_path());
  if (!graph) {
    (void)graph.error().to_string();
    return 0;
  }
  (void)rejuv::launch::keep_generations(graph->graph.sr());
  (void)rejuv::launch::mission_timeout(graph->graph.mission());
  for (const auto& s : graph->graph.services()) (void)rejuv::launch::rejuvenate(s);
  if (const rejuv::policy::Policy* policy = policy_at(graph->policy_path)) {
    for (const auto& finding : rejuv::policy::audit(*policy, *graph)) (void)finding.to_string();
  }
  return 0;
}
