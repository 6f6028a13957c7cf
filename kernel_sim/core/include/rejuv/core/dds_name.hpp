// The DDS topic name of a policy topic: "rejuv/<topic>" (docs/design.md §5), the default of a launch graph's
// bridges (idl/launch.proto Bridge.dds_name; launch::dds_name) and the names of the plant interface
// (rejuv/dds/plant_topics.hpp). The prefix is spelt here once; DdsName makes a full name at compile time, for
// the interfaces whose names are constants.
#pragma once

#include <cstddef>
#include <string_view>

namespace rejuv {

inline constexpr std::string_view kDdsNamePrefix = "rejuv/";

// kDdsNamePrefix + a policy topic's name, as a constant: `inline constexpr DdsName kGyro{"sensor_gyro"};`, then
// kGyro.view() == "rejuv/sensor_gyro" (a view of the object's own characters: keep the object alive).
template <std::size_t N>
struct DdsName {
  char text[kDdsNamePrefix.size() + N]{};  // the prefix, the topic's N - 1 characters and a terminating zero

  consteval explicit DdsName(const char (&topic)[N]) {
    for (std::size_t i = 0; i < kDdsNamePrefix.size(); ++i) text[i] = kDdsNamePrefix[i];
    for (std::size_t i = 0; i < N; ++i) text[kDdsNamePrefix.size() + i] = topic[i];
  }
  [[nodiscard]] constexpr std::string_view view() const { return {text, kDdsNamePrefix.size() + N - 1}; }
};

}  // namespace rejuv
