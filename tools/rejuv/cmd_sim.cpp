// Placeholder until this command lands (replaced by its implementation in the same change).
#include <cstdio>

#include "args.hpp"
#include "commands.hpp"

namespace rejuv::cli {
int run_sim(std::span<const std::string_view> /*args*/) {
  std::fprintf(stderr, "rejuv sim: not built yet\n");
  return static_cast<int>(Exit::BadInput);
}
}  // namespace rejuv::cli
