// The DDS topic name of a policy topic: "rejuv/<topic>" (docs/design.md §5), the default of a launch graph's
// bridges (idl/launch.proto Bridge.dds_name; launch::dds_name) and the names of the plant interface
// (rejuv/dds/plant_topics.hpp). The prefix is spelt here once; DdsName makes a full name at compile time, for
// the interfaces whose names are constants.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
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

// Whose names a topic has on DDS (docs/across_hosts.md "ROS 2 names"): Rejuv's, "rejuv/<topic>" with the IDL type
// name, or ROS 2's, "rt/<topic>" (what ROS 2's rmw layers make of the topic /<topic>) with the type
// "rejuv_msgs::msg::dds_::T_" in the default partition (msgs::dds_topic_type, rejuv/msgs/dds_naming.hpp).
enum class DdsNaming : std::uint8_t { Rejuv, Ros2 };

inline constexpr std::string_view kRos2TopicPrefix = "rt/";

// The DDS topic name of the policy topic `topic`: the one function that maps a topic to its DDS name.
[[nodiscard]] inline std::string dds_topic_name(std::string_view topic, DdsNaming naming) {
  switch (naming) {
    case DdsNaming::Rejuv: return std::string(kDdsNamePrefix) + std::string(topic);
    case DdsNaming::Ros2: return std::string(kRos2TopicPrefix) + std::string(topic);
  }
  return std::string(topic);
}

}  // namespace rejuv
