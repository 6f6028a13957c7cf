// The swept parameters of `rejuv sweep` (docs/sweep.md): a launch field named by its path on rejuv.proto.Launch
// (`sr.t_mc_s`, `sr.restricted_limit_fraction`, `attack.attacks[0].kind`, …), set through protobuf reflection,
// and the values it takes (a range `a:b:step`, a list `v1,v2,…` or one value). Every mistake is a precise
// message: an unknown field (with the fields there are), a repeated field without its index or past its end,
// a message named where a value is meant, a range on a field that is no number, an empty or inverted range.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "launch.pb.h"
#include "rejuv/core/result.hpp"
#include "sweep.pb.h"

namespace rejuv::cli::sweep {

// "a:b:step": a, a + step, … up to b inclusive (b itself when it is within 1e-9 steps of the grid); step > 0,
// a ≤ b. "v1,v2,…": those numbers. "v": one. At most kMaxValues values.
inline constexpr std::size_t kMaxValues = 10000;
[[nodiscard]] Result<std::vector<double>, std::string> parse_numbers(std::string_view text);

// Sets the field at `path` of `launch` from its text form: a number for numeric fields (an integer for the
// integer ones, in range), true/false, an enum value's name, any text for a string. Nothing is changed on
// an error.
[[nodiscard]] Result<void, std::string> set_field(proto::Launch& launch, std::string_view path,
                                                  std::string_view value);

// "PATH=VALUES" of --param, checked against `base` (the launch the sweep varies): the path exists and
// names a value field, and every value is one the field takes.
[[nodiscard]] Result<proto::SweepAxis, std::string> make_axis(const proto::Launch& base, std::string_view param);

// The unit of a field from its name's suffix (docs/conventions.md: units in identifiers): "t_mc_s" → "s".
[[nodiscard]] std::string unit_of(std::string_view path);

// An axis as the paper names it, for a figure: "T_MC [s] (sr.t_mc_s)" for the SR parameters of §IV–§VI, the
// path and its unit ("plant.wind_gust_m_s [m/s]") for any other field.
[[nodiscard]] std::string axis_label(std::string_view path, std::string_view unit);

}  // namespace rejuv::cli::sweep
