// Declared parameters (launch.hpp "declared parameters", idl/params.proto): loading a service's
// `<executable>.params.pbtxt`, checking a graph's `params` against it, and the table `rejuv run --help-service`
// prints. Every refusal is a LoadError at a file:line:column: the declaration's own, or the launch file's param.
#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <vector>

#include "rejuv/core/did_you_mean.hpp"
#include "validate.hpp"

namespace rejuv::launch {

namespace {

using Check = Result<void, LoadError>;
using Step = TextLocations::Step;

std::string_view type_name(proto::ParamType type) {
  switch (type) {
    case proto::NUMBER: return "number";
    case proto::INTEGER: return "integer";
    case proto::BOOL: return "bool";
    case proto::TEXT: return "text";
    case proto::ParamType_INT_MIN_SENTINEL_DO_NOT_USE_:
    case proto::ParamType_INT_MAX_SENTINEL_DO_NOT_USE_: break;
  }
  return "?";
}

bool is_numeric(proto::ParamType type) { return type == proto::NUMBER || type == proto::INTEGER; }

// "[0.01, 10]", "(0, +inf)", "" for an unbounded number; "0 or 1" for a switch; "" for a text.
std::string range_text(const proto::ParamDecl& d) {
  if (d.type() == proto::BOOL) return "0 or 1";
  if (!is_numeric(d.type()) || (!d.has_min() && !d.has_max())) return "";
  const std::string lo = d.has_min() ? detail::num(d.min()) : "-inf";
  const std::string hi = d.has_max() ? detail::num(d.max()) : "+inf";
  return std::string(d.has_min() && !d.min_exclusive() ? "[" : "(") + lo + ", " + hi +
         (d.has_max() && !d.max_exclusive() ? "]" : ")");
}

std::string choices_text(const proto::ParamDecl& d) {
  std::string out;
  for (const std::string& c : d.choices()) out += (out.empty() ? "" : "|") + c;
  return out;
}

std::string with_unit(const std::string& value, const proto::ParamDecl& d) {
  return d.unit().empty() ? value : value + " " + d.unit();
}

// Why `v` is not a value of the numeric declaration `d` ("" when it is): the one rule for a launch value and a
// declared default.
std::string number_problem(const proto::ParamDecl& d, double v) {
  if (!std::isfinite(v)) return "expected a finite number";
  switch (d.type()) {
    case proto::BOOL:
      return v == 0.0 || v == 1.0 ? "" : "expected 0 or 1 (a switch), got " + detail::num(v);
    case proto::INTEGER:
      if (v != std::floor(v)) return "expected a whole number, got " + detail::num(v);
      break;
    case proto::NUMBER: break;
    case proto::TEXT: return "expected a text (`text: \"…\"`), got a number";
    case proto::ParamType_INT_MIN_SENTINEL_DO_NOT_USE_:
    case proto::ParamType_INT_MAX_SENTINEL_DO_NOT_USE_: return "unknown type";
  }
  const bool below = d.has_min() && (d.min_exclusive() ? v <= d.min() : v < d.min());
  const bool above = d.has_max() && (d.max_exclusive() ? v >= d.max() : v > d.max());
  if (below || above) {
    return with_unit(detail::num(v), d) + " is out of range: expected " + range_text(d) +
           (d.unit().empty() ? "" : " " + d.unit());
  }
  return "";
}

std::string text_problem(const proto::ParamDecl& d, const std::string& v) {
  if (d.type() != proto::TEXT) {
    return "expected " + std::string(d.type() == proto::BOOL ? "`number: 0` or `number: 1`" : "a number (`number: …`)") +
           ", got the text \"" + v + "\"";
  }
  if (!d.choices().empty() && std::find(d.choices().begin(), d.choices().end(), v) == d.choices().end()) {
    std::vector<std::string> known(d.choices().begin(), d.choices().end());
    return "\"" + v + "\" is not one of " + choices_text(d) + did_you_mean(v, known);
  }
  return "";
}

// Checks one parsed declaration file; the first problem, at its field.
Check check_decls(const proto::ServiceParams& s, const TextLocations& locs) {
  const auto error = [&](int p, std::string_view field, std::string message) {
    const int index = field == "choices" ? 0 : -1;  // the first of a repeated field
    return fail(semantic_error(locs.locate({{"params", p}}, field, index), std::move(message)));
  };
  std::set<std::string_view> names;
  for (int p = 0; p < s.params_size(); ++p) {
    const proto::ParamDecl& d = s.params(p);
    const std::string what = "parameter \"" + d.name() + "\": ";
    if (!detail::is_plain_name(d.name()) || !detail::is_utf8(d.name())) {
      return error(p, "name", d.name().empty() ? std::string("a parameter without a `name`")
                                               : what + "a name uses only letters, digits, '_', '-', '.'");
    }
    if (!names.insert(d.name()).second) return error(p, "name", what + "declared twice");
    if (!proto::ParamType_IsValid(d.type())) {
      return error(p, "type", what + "unknown `type`: expected NUMBER, INTEGER, BOOL or TEXT");
    }
    if (d.help().empty()) return error(p, "name", what + "no `help`: say in one line what it changes");
    if (!detail::is_utf8(d.help()) || !detail::is_utf8(d.unit())) {
      return error(p, "help", what + "`help` and `unit` must be valid UTF-8");
    }
    if (!is_numeric(d.type()) && (d.has_min() || d.has_max() || d.min_exclusive() || d.max_exclusive())) {
      return error(p, d.has_min() ? "min" : "max",
                   what + "a " + std::string(type_name(d.type())) + " has no range: `min`/`max` are for NUMBER and INTEGER");
    }
    if (d.has_min() && !std::isfinite(d.min())) return error(p, "min", what + "`min` must be finite");
    if (d.has_max() && !std::isfinite(d.max())) return error(p, "max", what + "`max` must be finite");
    if (d.min_exclusive() && !d.has_min()) return error(p, "min_exclusive", what + "`min_exclusive` without a `min`");
    if (d.max_exclusive() && !d.has_max()) return error(p, "max_exclusive", what + "`max_exclusive` without a `max`");
    if (d.has_min() && d.has_max() &&
        (d.min() > d.max() || (d.min() == d.max() && (d.min_exclusive() || d.max_exclusive())))) {
      return error(p, "max", what + "the range " + range_text(d) + " is empty");
    }
    if (!d.choices().empty() && d.type() != proto::TEXT) {
      return error(p, "choices", what + "`choices` are for a TEXT parameter");
    }
    if (d.type() == proto::TEXT) {
      if (d.has_default_number()) return error(p, "default_number", what + "a TEXT parameter's default is `default_text`");
      if (d.has_default_text()) {
        if (std::string why = text_problem(d, d.default_text()); !why.empty()) {
          return error(p, "default_text", what + "the default " + why);
        }
      }
    } else {
      if (d.has_default_text()) {
        return error(p, "default_text", what + "a " + std::string(type_name(d.type())) + " parameter's default is `default_number`");
      }
      if (d.has_default_number()) {
        if (std::string why = number_problem(d, d.default_number()); !why.empty()) {
          return error(p, "default_number", what + "the default: " + why);
        }
      }
    }
  }
  return {};
}

Result<LoadedParams, LoadError> checked(proto::ServiceParams decls, TextLocations locs, const std::filesystem::path& path) {
  if (Check c = check_decls(decls, locs); !c) return fail(std::move(c.error()));
  return LoadedParams{.decls = std::move(decls), .locations = std::move(locs), .path = path};
}

std::string default_text(const proto::ParamDecl& d) {
  if (d.type() == proto::TEXT) return d.has_default_text() ? "\"" + d.default_text() + "\"" : "-";
  return d.has_default_number() ? detail::num(d.default_number()) : "-";
}

}  // namespace

std::filesystem::path params_file_of(const std::filesystem::path& executable) {
  std::filesystem::path file = executable;
  file += ".params.pbtxt";
  return file;
}

std::filesystem::path resolve_executable(std::string_view executable, const std::filesystem::path& service_dir) {
  const std::filesystem::path exe(executable);
  return exe.is_absolute() ? exe : service_dir / exe;
}

Result<LoadedParams, LoadError> load_params_file(const std::filesystem::path& path) {
  proto::ServiceParams decls;
  auto locs = load_textproto(path, decls);
  if (!locs) return fail(std::move(locs.error()));
  return checked(std::move(decls), std::move(*locs), path);
}

Result<LoadedParams, LoadError> parse_params_file(std::string_view text, const std::filesystem::path& as_path) {
  proto::ServiceParams decls;
  auto locs = parse_textproto(text, as_path.string(), decls);
  if (!locs) return fail(std::move(locs.error()));
  return checked(std::move(decls), std::move(*locs), as_path);
}

Result<std::optional<LoadedParams>, LoadError> declared_params_of(const std::filesystem::path& executable) {
  const std::filesystem::path file = params_file_of(executable);
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::optional<LoadedParams>{};
  auto loaded = load_params_file(file);
  if (!loaded) return fail(std::move(loaded.error()));
  return std::optional<LoadedParams>(std::move(*loaded));
}

Result<void, LoadError> check_service_params(const LoadedLaunch& loaded, int service_index, const LoadedParams& declared) {
  const proto::ServiceSpec& s = loaded.graph.services(service_index);
  const auto& decls = declared.decls.params();
  std::vector<std::string> names;
  names.reserve(static_cast<std::size_t>(decls.size()));
  for (const proto::ParamDecl& d : decls) names.push_back(d.name());
  for (int p = 0; p < s.params_size(); ++p) {
    const proto::Param& param = s.params(p);
    const auto at = [&](std::string_view field) {
      return loaded.locations.locate({{"services", service_index}, {"params", p}}, field);
    };
    const std::string owner = "service \"" + s.name() + "\"";
    const auto d = std::find_if(decls.begin(), decls.end(), [&](const proto::ParamDecl& x) { return x.name() == param.name(); });
    if (d == decls.end()) {
      std::string known;
      for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
      return fail(semantic_error(
          at("name"), owner + " has no parameter \"" + param.name() + "\"" + did_you_mean(param.name(), names) +
                          ": it declares " + (known.empty() ? std::string("none") : known) + " (" +
                          declared.path.string() + "; `rejuv run --help-service " + s.name() + " " +
                          loaded.path.string() + "`)"));
    }
    std::string why;
    std::string_view field;
    switch (param.value_case()) {
      case proto::Param::kNumber:
        field = "number";
        why = number_problem(*d, param.number());
        break;
      case proto::Param::kText:
        field = "text";
        why = text_problem(*d, param.text());
        break;
      case proto::Param::VALUE_NOT_SET:
        field = "name";
        why = std::string("no value: expected ") + (d->type() == proto::TEXT ? "`text: \"…\"`" : "`number: …`");
        break;
    }
    if (!why.empty()) {
      return fail(semantic_error(at(field), owner + ", parameter \"" + param.name() + "\" (" +
                                               std::string(type_name(d->type())) + "): " + why));
    }
  }
  return {};
}

Result<void, LoadError> check_declared_params(const LoadedLaunch& loaded, const std::filesystem::path& service_dir) {
  for (int i = 0; i < loaded.graph.services_size(); ++i) {
    auto declared = declared_params_of(resolve_executable(loaded.graph.services(i).executable(), service_dir));
    if (!declared) return fail(std::move(declared.error()));
    if (!*declared) continue;  // not declared: not checked
    if (auto ok = check_service_params(loaded, i, **declared); !ok) return ok;
  }
  return {};
}

std::string format_declared_params(const proto::ServiceParams& decls) {
  struct Row {
    std::string name, type, value, range, unit, help;
  };
  std::vector<Row> rows{{"NAME", "TYPE", "DEFAULT", "RANGE/CHOICES", "UNIT", "HELP"}};
  for (const proto::ParamDecl& d : decls.params()) {
    rows.push_back(Row{.name = d.name(),
                       .type = std::string(type_name(d.type())),
                       .value = default_text(d),
                       .range = d.type() == proto::TEXT ? choices_text(d) : range_text(d),
                       .unit = d.unit(),
                       .help = d.help()});
  }
  std::size_t w[5] = {};
  for (const Row& r : rows) {
    const std::string* cols[5] = {&r.name, &r.type, &r.value, &r.range, &r.unit};
    for (std::size_t c = 0; c < 5; ++c) w[c] = std::max({w[c], cols[c]->size(), std::size_t{1}});
  }
  std::string out;
  for (const Row& r : rows) {
    const std::string* cols[5] = {&r.name, &r.type, &r.value, &r.range, &r.unit};
    std::string line = " ";
    for (std::size_t c = 0; c < 5; ++c) {
      const std::string cell = cols[c]->empty() ? "-" : *cols[c];
      line += " " + cell + std::string(w[c] - cell.size() + 1, ' ');
    }
    out += line + " " + r.help + "\n";
  }
  return out;
}

}  // namespace rejuv::launch
