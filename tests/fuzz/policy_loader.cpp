// Fuzz target: the policy loader and its audit (kernel_sim/policy, docs/design.md §4). Text → parse_policy → (if it
// loads) audit, compile to the kernel's per-mode table and build the capability system from it. Bad text
// must give a LoadError with a location, never a crash or an abort.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "rejuv/cap/cap_system.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/policy.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto policy = rejuv::policy::parse_policy(text, "fuzz.policy.pbtxt");
  if (!policy) {
    (void)policy.error().to_string();
    return 0;
  }
  for (const auto& finding : rejuv::policy::audit(*policy)) (void)finding.to_string();
  const rejuv::cap::ModeTable table = rejuv::policy::compile(*policy);
  auto caps = rejuv::cap::CapSystem::create(table, rejuv::cap::CapSystemConfig{.cspace_slots = 256,
                                                                                .audit_capacity = 64,
                                                                                .initial_mode = rejuv::SrMode::MC});
  if (!caps) (void)caps.error().to_string();
  return 0;
}
