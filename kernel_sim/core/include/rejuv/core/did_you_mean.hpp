// The "did you mean" of every loader (policy, launch graph, declared parameters): a misspelt name is answered
// with the declared name it most likely meant.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>

namespace rejuv {

// Levenshtein distance: insertions, deletions and substitutions, one edit each.
[[nodiscard]] std::size_t edit_distance(std::string_view a, std::string_view b);

// " (did you mean \"x\"?)" when one of `known` is at most two edits from `name` (a likely typo); "" otherwise.
[[nodiscard]] std::string did_you_mean(std::string_view name, std::span<const std::string> known);

}  // namespace rejuv
