// The launch loader's entry points (launch.hpp): reading and parsing a *.launch.pbtxt (rejuv_textproto keeps
// every field's file:line:column), then the checks of validate.cpp; and the lexical rules those checks apply to
// names and texts (validate.hpp). The defaults and accessors are in defaults.cpp.
#include "rejuv/launch/launch.hpp"

#include <cstdint>
#include <cstdio>

#include "validate.hpp"

namespace rejuv::launch {

namespace detail {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

bool is_plain_name(std::string_view s) {
  if (s.empty()) {
    return false;
  }
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.';
    if (!ok) {
      return false;
    }
  }
  return true;
}

bool is_utf8(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;
    std::uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xE0U) == 0xC0U) {
      n = 1;
      cp = c & 0x1FU;
    } else if ((c & 0xF0U) == 0xE0U) {
      n = 2;
      cp = c & 0x0FU;
    } else if ((c & 0xF8U) == 0xF0U) {
      n = 3;
      cp = c & 0x07U;
    } else {
      return false;
    }
    if (i + n >= s.size()) {
      return false;
    }
    for (std::size_t k = 1; k <= n; ++k) {
      const auto cc = static_cast<unsigned char>(s[i + k]);
      if ((cc & 0xC0U) != 0x80U) {
        return false;
      }
      cp = (cp << 6U) | (cc & 0x3FU);
    }
    const std::uint32_t min = n == 1 ? 0x80U : n == 2 ? 0x800U : 0x10000U;
    if (cp < min || cp > 0x10FFFFU || (cp >= 0xD800U && cp <= 0xDFFFU)) {
      return false;
    }
    i += n + 1;
  }
  return true;
}

std::string kind_list(const std::vector<proto::AttackKind>& kinds) {
  if (kinds.empty()) {
    return "none";
  }
  std::string out;
  for (const proto::AttackKind k : kinds) {
    out += (out.empty() ? "" : ", ") + proto::AttackKind_Name(k);
  }
  return out;
}

}  // namespace detail

Result<LoadedLaunch, LoadError> load_launch(const std::filesystem::path& path) {
  proto::Launch graph;
  auto locs = load_textproto(path, graph);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return detail::validate(std::move(graph), std::move(*locs), path);
}

Result<LoadedLaunch, LoadError> parse_launch(std::string_view text, const std::filesystem::path& as_path) {
  proto::Launch graph;
  auto locs = parse_textproto(text, as_path.string(), graph);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return detail::validate(std::move(graph), std::move(*locs), as_path);
}

}  // namespace rejuv::launch
