// Durations are std::chrono types end to end (docs/conventions.md): no bare `double seconds` in an API.
#pragma once

#include <chrono>

namespace rejuv {

using Seconds = std::chrono::duration<double>;  // physics and control: fractional seconds
using Nanos = std::chrono::nanoseconds;         // timestamps and the kernel clock

[[nodiscard]] constexpr Nanos to_nanos(Seconds s) { return std::chrono::duration_cast<Nanos>(s); }
[[nodiscard]] constexpr Seconds to_seconds(Nanos n) { return std::chrono::duration_cast<Seconds>(n); }

}  // namespace rejuv
