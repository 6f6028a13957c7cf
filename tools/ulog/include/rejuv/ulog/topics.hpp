// The ULog formats of the project's topic types (docs/ulog.md), derived from the IDL: the member names come
// from the .idl files at build time (cmake/IdlFields.cmake → IdlFields<CType>), the types, sizes and offsets
// from idlc's C structs. A topic message in the log is a uint64 `timestamp` [µs] followed by the routed
// payload byte for byte; the format names the struct's fields in order, nested structs and arrays of them
// flattened ("gyro_0.omega_B_rad_s": some readers, @foxglove/ulog among them, require a timestamp in every
// nested type), and `_paddingN` fields wherever the C struct has padding.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>
#include <vector>

#include "rejuv/ulog/writer.hpp"

namespace rejuv::ulog {

struct FieldAt {
  Field field;
  std::size_t offset = 0;  // in the C struct [bytes]
};

// One topic type of REJUV_TOPIC_TYPES (idl/include/rejuv/msgs/topic_types.hpp).
struct TopicLayout {
  std::string_view idl_name;     // e.g. "rejuv::msg::SensorGyro"
  std::size_t size = 0;          // sizeof the C struct
  std::vector<FieldAt> members;  // flattened, padding included: their sizes add up to `size`
};

// Every topic type's layout, in the order of REJUV_TOPIC_TYPES.
[[nodiscard]] std::span<const TopicLayout> topic_layouts();
[[nodiscard]] const TopicLayout* find_layout(std::string_view idl_name);

// The format of a topic named `format_name` (e.g. the policy object "sensor_gyro") of this layout:
// `uint64_t timestamp;` then the members.
[[nodiscard]] Format topic_format(std::string_view format_name, const TopicLayout& layout);
// The format of a topic whose fields are not known here (a type declared in a policy, not in the project's
// IDL): `uint64_t timestamp;` then its `size` bytes as `uint8_t[size] data`.
[[nodiscard]] Format raw_format(std::string_view format_name, std::size_t size);

}  // namespace rejuv::ulog
