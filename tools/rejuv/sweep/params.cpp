#include "sweep/params.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "rejuv/core/graph_values.hpp"

namespace rejuv::cli::sweep {
namespace {

namespace pb = google::protobuf;

std::string fields_of(const pb::Descriptor& d) {
  std::string out;
  for (int i = 0; i < d.field_count(); ++i) out += (i > 0 ? ", " : "") + std::string(d.field(i)->name());
  return out;
}

std::optional<double> number(std::string_view text) {
  double v = 0;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, v);
  if (ec != std::errc{} || p != end || text.empty() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string format_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}

// One step of a path: a field and, for a repeated field, the element.
struct Step {
  const pb::FieldDescriptor* field = nullptr;
  int index = -1;
};

// Walks `path` on `root` (the launch), checking each step against the message it is in (and each index against
// the element count of `root`'s repeated fields). The last step is a value field (not a message).
Result<std::vector<Step>, std::string> resolve(const pb::Message& root, std::string_view path) {
  if (path.empty()) return fail(std::string("empty field path: expected e.g. sr.t_mc_s"));
  std::vector<Step> steps;
  const pb::Message* at = &root;  // nullptr once past an unset message (counts are then 0)
  const pb::Descriptor* d = root.GetDescriptor();
  std::string walked;
  std::string_view rest = path;
  while (true) {
    const auto dot = rest.find('.');
    std::string_view part = rest.substr(0, dot);
    rest = dot == std::string_view::npos ? std::string_view{} : rest.substr(dot + 1);
    int index = -1;
    if (const auto open = part.find('['); open != std::string_view::npos) {
      const std::string_view idx = part.substr(open + 1);
      unsigned value = 0;
      const auto [p, ec] = std::from_chars(idx.data(), idx.data() + idx.size(), value);
      if (ec != std::errc{} || p == idx.data() || p + 1 != idx.data() + idx.size() || *p != ']') {
        return fail("'" + std::string(path) + "': bad index in '" + std::string(part) + "': expected name[N]");
      }
      index = static_cast<int>(value);
      part = part.substr(0, open);
    }
    if (d == nullptr) {
      return fail("'" + std::string(path) + "': " + walked + " is a value, it has no field '" + std::string(part) + "'");
    }
    const pb::FieldDescriptor* f = d->FindFieldByName(std::string(part));
    if (f == nullptr) {
      return fail("'" + std::string(path) + "': " + (walked.empty() ? std::string(d->full_name()) : walked + " (" + std::string(d->full_name()) + ")") +
                  " has no field '" + std::string(part) + "'; its fields: " + fields_of(*d));
    }
    walked += (walked.empty() ? "" : ".") + std::string(part);
    if (f->is_map()) return fail("'" + std::string(path) + "': " + walked + " is a map: not sweepable");
    if (f->is_repeated()) {
      if (index < 0) {
        return fail("'" + std::string(path) + "': " + walked + " is repeated: name one element, e.g. " + walked + "[0]");
      }
      const int count = at != nullptr ? at->GetReflection()->FieldSize(*at, f) : 0;
      if (index >= count) {
        return fail("'" + std::string(path) + "': " + walked + "[" + std::to_string(index) + "]: the launch has " +
                    std::to_string(count) + " element" + (count == 1 ? "" : "s"));
      }
      walked += "[" + std::to_string(index) + "]";
    } else if (index >= 0) {
      return fail("'" + std::string(path) + "': " + walked + " is not repeated: no [" + std::to_string(index) + "]");
    }
    steps.push_back(Step{f, index});
    if (f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
      if (at != nullptr) {
        const pb::Reflection* r = at->GetReflection();
        if (f->is_repeated()) {
          at = &r->GetRepeatedMessage(*at, f, index);
        } else {
          at = r->HasField(*at, f) ? &r->GetMessage(*at, f) : nullptr;
        }
      }
      d = f->message_type();
    } else {
      d = nullptr;
    }
    if (rest.empty()) break;
  }
  if (d != nullptr) {
    return fail("'" + std::string(path) + "': " + walked + " is a message (" + std::string(d->full_name()) +
                "), not a value: name one of its fields: " + fields_of(*d));
  }
  return steps;
}

// (protobuf's CppType has a MAX_CPPTYPE sentinel, so these are ifs, not exhaustive switches.)
bool is_numeric(const pb::FieldDescriptor& f) {
  const auto t = f.cpp_type();
  return t == pb::FieldDescriptor::CPPTYPE_DOUBLE || t == pb::FieldDescriptor::CPPTYPE_FLOAT ||
         t == pb::FieldDescriptor::CPPTYPE_INT32 || t == pb::FieldDescriptor::CPPTYPE_INT64 ||
         t == pb::FieldDescriptor::CPPTYPE_UINT32 || t == pb::FieldDescriptor::CPPTYPE_UINT64;
}

std::string type_name(const pb::FieldDescriptor& f) {
  if (f.cpp_type() == pb::FieldDescriptor::CPPTYPE_ENUM) return "an enum (" + std::string(f.enum_type()->full_name()) + ")";
  if (f.cpp_type() == pb::FieldDescriptor::CPPTYPE_BOOL) return "a bool";
  if (f.cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING) return "a string";
  return std::string("a ") + f.cpp_type_name();
}

// The integer in `text` if it is one within [lo, hi].
template <class T>
Result<T, std::string> integer(std::string_view text, const std::string& path) {
  const auto v = number(text);
  constexpr double lo = static_cast<double>(std::numeric_limits<T>::min());
  constexpr double hi = static_cast<double>(std::numeric_limits<T>::max());
  if (!v || std::floor(*v) != *v || *v < lo || *v > hi) {
    return fail(path + ": expected an integer in [" + format_number(lo) + ", " + format_number(hi) + "], got '" +
                std::string(text) + "'");
  }
  return static_cast<T>(*v);
}

}  // namespace

Result<std::vector<double>, std::string> parse_numbers(std::string_view text) {
  if (text.empty()) return fail(std::string("empty value: expected a:b:step, v1,v2,... or one number"));
  std::vector<double> out;
  if (text.find(':') != std::string_view::npos) {
    std::vector<std::string_view> parts;
    std::string_view rest = text;
    while (true) {
      const auto colon = rest.find(':');
      parts.push_back(rest.substr(0, colon));
      if (colon == std::string_view::npos) break;
      rest = rest.substr(colon + 1);
    }
    if (parts.size() != 3) return fail("range '" + std::string(text) + "': expected a:b:step (three numbers)");
    std::optional<double> v[3];
    for (int i = 0; i < 3; ++i) {
      v[i] = number(parts[static_cast<std::size_t>(i)]);
      if (!v[i]) {
        return fail("range '" + std::string(text) + "': '" + std::string(parts[static_cast<std::size_t>(i)]) +
                    "' is not a finite number");
      }
    }
    const double a = *v[0], b = *v[1], step = *v[2];
    if (!(step > 0)) return fail("range '" + std::string(text) + "': the step must be > 0");
    if (a > b) return fail("range '" + std::string(text) + "': inverted (" + format_number(a) + " > " + format_number(b) + ")");
    const double n = std::floor((b - a) / step + 1e-9) + 1;
    if (n > static_cast<double>(kMaxValues)) {
      return fail("range '" + std::string(text) + "': " + format_number(n) + " values, more than " +
                  std::to_string(kMaxValues));
    }
    for (int i = 0; i < static_cast<int>(n); ++i) {
      // Rounded to 12 digits, so that 0.2 + 4 · 0.025 is 0.3 and not 0.30000000000000004.
      out.push_back(*number(format_number(a + i * step)));
    }
    return out;
  }
  std::string_view rest = text;
  while (true) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    const auto v = number(item);
    if (!v) return fail("'" + std::string(item) + "' in '" + std::string(text) + "' is not a finite number");
    out.push_back(*v);
    if (out.size() > kMaxValues) return fail("more than " + std::to_string(kMaxValues) + " values");
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  return out;
}

Result<void, std::string> set_field(proto::Launch& launch, std::string_view path, std::string_view value) {
  auto steps = resolve(launch, path);
  if (!steps) return fail(std::move(steps.error()));
  const std::string where(path);
  // Parse the value before touching the launch (nothing changes on an error).
  const pb::FieldDescriptor* leaf = steps->back().field;
  pb::Message* m = &launch;
  const auto descend = [&] {
    for (std::size_t i = 0; i + 1 < steps->size(); ++i) {
      const Step& s = (*steps)[i];
      const pb::Reflection* r = m->GetReflection();
      m = s.index >= 0 ? r->MutableRepeatedMessage(m, s.field, s.index) : r->MutableMessage(m, s.field);
    }
    return m->GetReflection();
  };
  const int index = steps->back().index;
  // The four integer types differ only in their range and their reflection setters.
  const auto set_integer = [&]<class T>(auto set, auto set_repeated) -> Result<void, std::string> {
    const auto v = integer<T>(value, where);
    if (!v) return fail(v.error());
    const pb::Reflection* r = descend();
    index >= 0 ? (r->*set_repeated)(m, leaf, index, *v) : (r->*set)(m, leaf, *v);
    return {};
  };
  switch (leaf->cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_MESSAGE: break;  // resolve() refuses a message leaf
    case pb::FieldDescriptor::CPPTYPE_DOUBLE:
    case pb::FieldDescriptor::CPPTYPE_FLOAT: {
      const auto v = number(value);
      if (!v) return fail(where + ": expected a finite number, got '" + std::string(value) + "'");
      const pb::Reflection* r = descend();
      if (leaf->cpp_type() == pb::FieldDescriptor::CPPTYPE_DOUBLE) {
        index >= 0 ? r->SetRepeatedDouble(m, leaf, index, *v) : r->SetDouble(m, leaf, *v);
      } else {
        const auto f = static_cast<float>(*v);
        index >= 0 ? r->SetRepeatedFloat(m, leaf, index, f) : r->SetFloat(m, leaf, f);
      }
      return {};
    }
    case pb::FieldDescriptor::CPPTYPE_INT32:
      return set_integer.template operator()<std::int32_t>(&pb::Reflection::SetInt32, &pb::Reflection::SetRepeatedInt32);
    case pb::FieldDescriptor::CPPTYPE_INT64:
      return set_integer.template operator()<std::int64_t>(&pb::Reflection::SetInt64, &pb::Reflection::SetRepeatedInt64);
    case pb::FieldDescriptor::CPPTYPE_UINT32:
      return set_integer.template operator()<std::uint32_t>(&pb::Reflection::SetUInt32,
                                                            &pb::Reflection::SetRepeatedUInt32);
    case pb::FieldDescriptor::CPPTYPE_UINT64:
      return set_integer.template operator()<std::uint64_t>(&pb::Reflection::SetUInt64,
                                                            &pb::Reflection::SetRepeatedUInt64);
    case pb::FieldDescriptor::CPPTYPE_BOOL: {
      if (value != "true" && value != "false") {
        return fail(where + ": expected true or false, got '" + std::string(value) + "'");
      }
      const pb::Reflection* r = descend();
      index >= 0 ? r->SetRepeatedBool(m, leaf, index, value == "true") : r->SetBool(m, leaf, value == "true");
      return {};
    }
    case pb::FieldDescriptor::CPPTYPE_ENUM: {
      const pb::EnumValueDescriptor* e = leaf->enum_type()->FindValueByName(std::string(value));
      if (e == nullptr) {
        std::string names;
        for (int i = 0; i < leaf->enum_type()->value_count(); ++i) {
          names += (i > 0 ? ", " : "") + std::string(leaf->enum_type()->value(i)->name());
        }
        return fail(where + ": '" + std::string(value) + "' is no value of " +
                    std::string(leaf->enum_type()->full_name()) + "; its values: " + names);
      }
      const pb::Reflection* r = descend();
      index >= 0 ? r->SetRepeatedEnum(m, leaf, index, e) : r->SetEnum(m, leaf, e);
      return {};
    }
    case pb::FieldDescriptor::CPPTYPE_STRING: {
      const pb::Reflection* r = descend();
      index >= 0 ? r->SetRepeatedString(m, leaf, index, std::string(value)) : r->SetString(m, leaf, std::string(value));
      return {};
    }
  }
  return fail(where + ": not a value field");
}

Result<proto::SweepAxis, std::string> make_axis(const proto::Launch& base, std::string_view param) {
  const auto eq = param.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    return fail("--param '" + std::string(param) + "': expected PATH=VALUES, e.g. sr.t_mc_s=0.2:0.3:0.025");
  }
  const std::string_view path = param.substr(0, eq);
  const std::string_view text = param.substr(eq + 1);
  auto steps = resolve(base, path);
  if (!steps) return fail("--param " + steps.error());
  const pb::FieldDescriptor& leaf = *steps->back().field;
  proto::SweepAxis axis;
  axis.set_path(std::string(path));
  axis.set_unit(unit_of(path));
  if (text.empty()) return fail("--param " + std::string(path) + ": no values after '='");
  if (is_numeric(leaf)) {
    auto values = parse_numbers(text);
    if (!values) return fail("--param " + std::string(path) + ": " + values.error());
    for (const double v : *values) axis.add_values(format_number(v));
  } else {
    if (text.find(':') != std::string_view::npos) {
      return fail("--param " + std::string(path) + ": a range (a:b:step) needs a numeric field; " + std::string(path) +
                  " is " + type_name(leaf) + ": list its values, e.g. v1,v2");
    }
    std::string_view rest = text;
    while (true) {
      const auto comma = rest.find(',');
      axis.add_values(std::string(rest.substr(0, comma)));
      if (comma == std::string_view::npos) break;
      rest = rest.substr(comma + 1);
    }
  }
  // Every value must be one the field takes (checked on a copy).
  for (const std::string& v : axis.values()) {
    proto::Launch copy = base;
    if (auto set = set_field(copy, path, v); !set) return fail("--param " + set.error());
  }
  return axis;
}

std::string axis_label(std::string_view path, std::string_view unit) {
  namespace gv = graph_values;
  // A key's symbol names its axis; the fraction and the period read better spelt out on a plot.
  const std::pair<std::string_view, std::string_view> names[] = {
      {gv::kTmc.name, gv::kTmc.symbol},
      {gv::kTest.name, gv::kTest.symbol},
      {gv::kRhoM.name, gv::kRhoM.symbol},
      {gv::kRhoS.name, gv::kRhoS.symbol},
      {gv::kTmin.name, gv::kTmin.symbol},
      {gv::kRestrictedLimitFraction.name, "Ū / U"},
      {gv::kCheckPeriod.name, "check period of (1)"},
      {gv::kRearmEnabled.name, gv::kRearmEnabled.symbol}};
  const std::string units = unit.empty() ? "" : " [" + std::string(unit) + "]";
  for (const auto& [p, name] : names) {
    if (p == path) return std::string(name) + units + " (" + std::string(path) + ")";
  }
  return std::string(path) + units;
}

std::string unit_of(std::string_view path) {
  const std::string_view name = path.substr(path.rfind('.') == std::string_view::npos ? 0 : path.rfind('.') + 1);
  const std::pair<std::string_view, std::string_view> suffixes[] = {
      {"_rad_s", "rad/s"}, {"_m_s", "m/s"}, {"_ms", "ms"}, {"_hz", "Hz"}, {"_mb", "MiB"},
      {"_rad", "rad"},     {"_s", "s"},     {"_m", "m"}};
  if (name.starts_with("rho_")) return "";  // ρ_M, ρ_s (§IV-A): the suffix is a name, not a unit
  for (const auto& [suffix, unit] : suffixes) {
    if (name.ends_with(suffix)) return std::string(unit);
  }
  return "";
}

}  // namespace rejuv::cli::sweep
