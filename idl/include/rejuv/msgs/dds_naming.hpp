// How a topic is named on DDS: Rejuv's own names ("rejuv/<topic>", the IDL type name) or ROS 2's, so that
// ROS 2 tools and nodes see the graph (docs/across_hosts.md "ROS 2 names"). ROS 2 (rmw_cyclonedds, rmw_fastrtps)
// maps a topic /<topic> to the DDS topic "rt/<topic>" and a message pkg/msg/T to the DDS type
// "pkg::msg::dds_::T_", in the default partition; the messages are the generated package `rejuv_msgs`
// (tools/ros2_msgs), one per IDL struct, whose CDR is the IDL struct's. This is the one place that maps a
// topic to its DDS name and type: the launch graph's bridges (launch::dds_name), the kernel's bridge and the
// plant's endpoints, and the cross-host link ask it (the name alone: rejuv::dds_topic_name, in rejuv_core).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "rejuv/core/dds_name.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::msgs {

using rejuv::DdsNaming;  // Rejuv or Ros2; the topic's DDS name is rejuv::dds_topic_name (rejuv/core/dds_name.hpp)

using rejuv::kRos2Package;  // the generated interface package (rejuv/core/dds_name.hpp)
inline constexpr std::string_view kIdlModule = "rejuv::msg::";  // the IDL module of every topic type

// A topic as DDS sees it: its DDS topic name, and its type whose descriptor carries the DDS type name.
// `type->name` stays the IDL name (the policy's), so endpoints compare types as before.
struct DdsTopic {
  std::string name;
  const TopicType* type = nullptr;
};

// The type to create DDS endpoints of `type` with: `type` itself (Rejuv), or the same struct under the ROS 2
// type name (a copy of idlc's descriptor with its m_typename replaced). `type` must be of all_topic_types().
[[nodiscard]] const TopicType& dds_topic_type(const TopicType& type, DdsNaming naming);
// Both at once.
[[nodiscard]] DdsTopic dds_topic(std::string_view topic, const TopicType& type, DdsNaming naming);

// "rejuv::msg::VehicleStateEstimate" -> "VehicleStateEstimate": the ROS 2 message name of an IDL struct
// (empty when the name is not in kIdlModule).
[[nodiscard]] std::string_view ros2_message_name(std::string_view idl_name);
// "rejuv::msg::VehicleStateEstimate" -> "rejuv_msgs::msg::dds_::VehicleStateEstimate_".
[[nodiscard]] std::string ros2_dds_type_name(std::string_view idl_name);

}  // namespace rejuv::msgs
