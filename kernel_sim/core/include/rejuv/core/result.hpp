// Errors are values (docs/conventions.md): every fallible call returns Result<T, E> = std::expected<T, E>.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <expected>

namespace rejuv {

template <class T, class E>
using Result = std::expected<T, E>;

template <class E>
[[nodiscard]] constexpr std::unexpected<E> fail(E error) {
  return std::unexpected<E>(std::move(error));
}

}  // namespace rejuv

// Always-on check of an internal invariant (never of user input): prints where and why, then aborts.
#define REJUV_ASSERT(cond, what)                                                                \
  do {                                                                                          \
    if (!(cond)) [[unlikely]] {                                                                 \
      std::fprintf(stderr, "rejuv: internal invariant broken at %s:%d: %s (%s)\n", __FILE__,    \
                   __LINE__, what, #cond);                                                      \
      std::abort();                                                                             \
    }                                                                                           \
  } while (false)
