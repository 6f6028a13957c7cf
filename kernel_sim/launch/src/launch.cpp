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

namespace {

// The folder of the file that wrote a field.
std::filesystem::path writer_folder(const TextLocations& locs, std::initializer_list<TextLocations::Step> path,
                                    std::string_view field, int index = -1) {
  return std::filesystem::path(locs.locate(path, field, index).file).parent_path();
}

// A relative path a fragment wrote, made relative to the root file's folder (where every reader of the
// graph resolves it), so that a fragment's paths mean what they say in the fragment.
void rebase(std::string& value, const std::filesystem::path& writer, const std::filesystem::path& root) {
  const std::filesystem::path p(value);
  if (value.empty() || p.is_absolute() || writer == root) {
    return;
  }
  const std::filesystem::path relative = (writer / p).lexically_normal().lexically_relative(root);
  value = relative.empty() ? std::filesystem::absolute(writer / p).lexically_normal().string() : relative.string();
}

Result<LoadedLaunch, LoadError> composed(proto::Launch graph, TextLocations locs, const std::filesystem::path& path) {
  const std::filesystem::path root = path.parent_path();
  rebase(*graph.mutable_policy(), writer_folder(locs, {}, "policy"), root);
  if (graph.has_dds()) {
    rebase(*graph.mutable_dds()->mutable_config(), writer_folder(locs, {{"dds", -1}}, "config"), root);
  }
  if (graph.has_network()) {
    rebase(*graph.mutable_network()->mutable_signing_key_file(),
           writer_folder(locs, {{"network", -1}}, "signing_key_file"), root);
  }
  // A relative executable found in a folder of `service_path` is named by its absolute path from here on.
  std::vector<std::filesystem::path> search;
  for (int i = 0; i < graph.service_path_size(); ++i) {
    const std::filesystem::path dir(graph.service_path(i));
    search.push_back(dir.is_relative() ? writer_folder(locs, {}, "service_path", i) / dir : dir);
  }
  const auto find_executable = [&](std::string& exe) {
    if (exe.empty() || std::filesystem::path(exe).is_absolute()) return;
    for (const std::filesystem::path& dir : search) {
      std::error_code ec;
      if (std::filesystem::is_regular_file(dir / exe, ec)) {
        exe = std::filesystem::absolute(dir / exe, ec).lexically_normal().string();
        return;
      }
    }
  };
  for (proto::ServiceSpec& s : *graph.mutable_services()) {
    find_executable(*s.mutable_executable());
  }
  if (graph.has_plant()) {
    find_executable(*graph.mutable_plant()->mutable_executable());
  }
  std::vector<ExtraFragment> policy_includes;
  for (int i = 0; i < graph.policy_include_size(); ++i) {
    const std::filesystem::path named(graph.policy_include(i));
    const SourceLocation at = locs.locate({}, "policy_include", i);
    policy_includes.push_back(
        ExtraFragment{named.is_relative() ? std::filesystem::path(at.file).parent_path() / named : named, at});
  }
  auto loaded = detail::validate(std::move(graph), std::move(locs), path);
  if (loaded) {
    loaded->policy_includes = std::move(policy_includes);
  }
  return loaded;
}

}  // namespace

Result<LoadedLaunch, LoadError> load_launch(const std::filesystem::path& path) {
  proto::Launch graph;
  auto locs = load_composed_textproto(path, graph);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return composed(std::move(graph), std::move(*locs), path);
}

Result<LoadedLaunch, LoadError> load_launch(std::span<const std::filesystem::path> paths) {
  if (paths.size() == 1) return load_launch(paths.front());
  REJUV_ASSERT(!paths.empty(), "load_launch: no launch file");
  // A root made of nothing but the files' includes, named in messages for what it is.
  std::string text;
  std::string names;
  for (const std::filesystem::path& p : paths) {
    std::string quoted;
    for (const char c : std::filesystem::absolute(p).lexically_normal().string()) {
      if (c == '"' || c == '\\') quoted += '\\';
      quoted += c;
    }
    text += "include: \"" + quoted + "\"\n";
    names += (names.empty() ? "" : " + ") + p.filename().string();
  }
  return parse_launch(text, paths.front().parent_path() / ("(" + names + ")"));
}

Result<LoadedLaunch, LoadError> parse_launch(std::string_view text, const std::filesystem::path& as_path) {
  proto::Launch graph;
  auto locs = parse_composed_textproto(text, as_path.string(), graph);
  if (!locs) {
    return fail(std::move(locs.error()));
  }
  return composed(std::move(graph), std::move(*locs), as_path);
}

}  // namespace rejuv::launch
