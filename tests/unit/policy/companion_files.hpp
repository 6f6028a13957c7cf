// The two-host graph of tests/across_hosts (companion.launch.pbtxt, companion.policy.pbtxt) as the policy's
// host tests read and edit it: the file's text, one edit of it, and findings as one string for messages.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/policy/audit.hpp"

namespace rejuv::policy::companion {

inline const std::filesystem::path kCompanionDir = std::filesystem::path(REJUV_SOURCE_DIR) / "tests" / "across_hosts";

inline std::string read(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// `text` with the first `from` replaced by `to` (a test's own text: `from` must be there).
inline std::string replaced(std::string text, std::string_view from, std::string_view to) {
  const std::size_t at = text.find(from);
  REJUV_ASSERT(at != std::string::npos, "test bug: text to replace not found");
  return text.replace(at, from.size(), to);
}

inline std::string all(const std::vector<Finding>& f) {
  std::string s;
  for (const Finding& x : f) s += x.to_string() + "\n";
  return s;
}

}  // namespace rejuv::policy::companion
