#include "rejuv/core/graph_values.hpp"

#include <cmath>
#include <cstdio>

namespace rejuv::graph_values {

namespace {

std::string num(double v) {
  std::array<char, 64> buf{};
  std::snprintf(buf.data(), buf.size(), "%g", v);
  return buf.data();
}

std::string with_unit(const std::string& number, Quantity q) {
  const std::string_view unit = unit_of(q);
  return unit.empty() ? number : number + " " + std::string(unit);
}

ValueError refused(std::string_view name, ValueError::Kind kind, std::string message) {
  return ValueError{.kind = kind, .key = std::string(name), .message = std::move(message)};
}

// The range in the file's unit; `lo`/`hi` are the bounds as numbers of that unit.
std::string range_in(std::string_view symbol, Quantity q, double lo, bool lo_open, double hi, bool hi_open) {
  if (std::isinf(hi)) return with_unit(std::string(symbol) + (lo_open ? " > " : " ≥ ") + num(lo), q);
  return with_unit(
      num(lo) + (lo_open ? " < " : " ≤ ") + std::string(symbol) + (hi_open ? " < " : " ≤ ") + num(hi), q);
}

template <class T>
bool inside(const Range<T>& r, T v) {
  const bool above = r.min_open ? v > r.min : v >= r.min;
  const bool below = r.max_open ? v < r.max : v <= r.max;
  return above && below;
}

// A switch or a count: an integer, or a double holding a whole number (a table in a test).
Result<double, ValueError> whole_or_number(std::string_view name, const Value& value) {
  if (const auto* i = std::get_if<std::int64_t>(&value)) return static_cast<double>(*i);
  const double d = std::get<double>(value);
  if (!std::isfinite(d)) return fail(refused(name, ValueError::Kind::NotFinite, "expected a finite number"));
  return d;
}

}  // namespace

std::string_view unit_of(Quantity quantity) {
  switch (quantity) {
    case Quantity::Duration: return "s";
    case Quantity::Length: return "m";
    case Quantity::Speed: return "m/s";
    case Quantity::Angle: return "rad";
    case Quantity::AngularRate: return "rad/s";
    case Quantity::Acceleration: return "m/s²";
    case Quantity::Switch:
    case Quantity::Fraction:
    case Quantity::Count: return "";
  }
  return "";
}

const Key<double>* rearm_std(std::string_view field) {
  for (const Key<double>* key : kRearmStds) {
    if (field_of(key->name) == field) return key;
  }
  return nullptr;
}

std::string_view field_of(std::string_view name) {
  const std::size_t dot = name.rfind('.');
  return dot == std::string_view::npos ? name : name.substr(dot + 1);
}

Nanos nanos_of_seconds(double seconds) { return std::chrono::round<Nanos>(Seconds(seconds)); }

Result<bool, ValueError> read(const Key<bool>& key, const std::optional<Value>& value) {
  if (!value) return key.fallback;
  auto v = whole_or_number(key.name, *value);
  if (!v) return fail(std::move(v.error()));
  if (*v != 0.0 && *v != 1.0) {
    return fail(refused(key.name, ValueError::Kind::OutOfRange, "expected 0 or 1, got " + num(*v)));
  }
  return *v == 1.0;
}

Result<Nanos, ValueError> read(const Key<Nanos>& key, const std::optional<Value>& value) {
  if (!value) return key.fallback;
  if (const auto* d = std::get_if<double>(&*value)) {
    if (!std::isfinite(*d)) return fail(refused(key.name, ValueError::Kind::NotFinite, "expected a finite number"));
    return fail(refused(key.name, ValueError::Kind::WrongType,
                        "a duration crosses as whole nanoseconds, got the number " + num(*d)));
  }
  const Nanos v{std::get<std::int64_t>(*value)};
  if (!in_range(key, v)) {
    return fail(refused(key.name, ValueError::Kind::OutOfRange,
                        "expected " + range_text(key) + ", got " + num(to_seconds(v).count()) + " s"));
  }
  return v;
}

Result<std::uint32_t, ValueError> read(const Key<std::uint32_t>& key, const std::optional<Value>& value) {
  if (!value) return key.fallback;
  auto v = whole_or_number(key.name, *value);
  if (!v) return fail(std::move(v.error()));
  if (*v != std::floor(*v) || *v < static_cast<double>(key.range.min) || *v > static_cast<double>(key.range.max) ||
      !in_range(key, static_cast<std::uint32_t>(*v))) {
    return fail(refused(key.name, ValueError::Kind::OutOfRange,
                        "expected a whole " + range_text(key) + ", got " + num(*v)));
  }
  return static_cast<std::uint32_t>(*v);
}

Result<double, ValueError> read(const Key<double>& key, const std::optional<Value>& value) {
  if (!value) return key.fallback;
  auto v = whole_or_number(key.name, *value);
  if (!v) return fail(std::move(v.error()));
  if (!in_range(key, *v)) {
    return fail(refused(key.name, ValueError::Kind::OutOfRange,
                        "expected " + range_text(key) + ", got " + with_unit(num(*v), key.quantity)));
  }
  return *v;
}

bool is_on(const Key<bool>& key, std::optional<double> number) {
  return number ? *number == 1.0 : key.fallback;
}

Value encode(const Key<bool>& /*key*/, bool value) { return std::int64_t{value ? 1 : 0}; }
Value encode(const Key<Nanos>& /*key*/, Nanos value) { return std::int64_t{value.count()}; }
Value encode(const Key<std::uint32_t>& /*key*/, std::uint32_t value) { return std::int64_t{value}; }
Value encode(const Key<double>& /*key*/, double value) { return value; }

bool in_range(const Key<Nanos>& key, Nanos value) { return inside(key.range, value); }
bool in_range(const Key<std::uint32_t>& key, std::uint32_t value) { return inside(key.range, value); }
bool in_range(const Key<double>& key, double value) { return std::isfinite(value) && inside(key.range, value); }

std::string range_text(const Key<Nanos>& key) {
  return range_in(key.symbol, key.quantity, to_seconds(key.range.min).count(), key.range.min_open,
                  to_seconds(key.range.max).count(), key.range.max_open);
}
std::string range_text(const Key<std::uint32_t>& key) {
  return range_in(key.symbol, key.quantity, key.range.min, key.range.min_open, key.range.max, key.range.max_open);
}
std::string range_text(const Key<double>& key) {
  return range_in(key.symbol, key.quantity, key.range.min, key.range.min_open, key.range.max, key.range.max_open);
}

}  // namespace rejuv::graph_values
