// printf-style formatting into std::string (g++ 12 has no <format>); checked by the compiler's -Wformat.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

namespace rejuv::flight::detail {

[[nodiscard]] __attribute__((format(printf, 1, 2))) inline std::string printf_string(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::va_list copy;
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  std::string out;
  if (n > 0) {
    out.resize(static_cast<std::size_t>(n) + 1);
    std::vsnprintf(out.data(), out.size(), format, args);
    out.resize(static_cast<std::size_t>(n));
  }
  va_end(args);
  return out;
}

}  // namespace rejuv::flight::detail
