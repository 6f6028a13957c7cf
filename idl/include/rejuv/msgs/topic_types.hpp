// The topic types of the whole system (idl/*.idl, compiled by idlc) as one table: name, size and Cyclone
// type descriptor of each fixed-size struct. The broker checks payload sizes against it (docs/design.md §5), the
// DDS bridge creates topics from it, and the SDK maps a C++ type to its name with TopicTraits.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

#include "control.h"
#include "sensors.h"
#include "sim.h"
#include "sr.h"
#include "state.h"

// X(CType, "IDL name"): every topic type. Adding an IDL struct that is a topic means adding it here.
#define REJUV_TOPIC_TYPES(X)                                   \
  X(rejuv_msg_SensorGyro, "rejuv::msg::SensorGyro")            \
  X(rejuv_msg_SensorAccel, "rejuv::msg::SensorAccel")          \
  X(rejuv_msg_SensorMag, "rejuv::msg::SensorMag")              \
  X(rejuv_msg_SensorBaro, "rejuv::msg::SensorBaro")            \
  X(rejuv_msg_SensorGps, "rejuv::msg::SensorGps")              \
  X(rejuv_msg_SensorCombined, "rejuv::msg::SensorCombined")    \
  X(rejuv_msg_VehicleStateEstimate, "rejuv::msg::VehicleStateEstimate") \
  X(rejuv_msg_GroundTruth, "rejuv::msg::GroundTruth")          \
  X(rejuv_msg_ActuatorControls, "rejuv::msg::ActuatorControls") \
  X(rejuv_msg_ActuatorOutputs, "rejuv::msg::ActuatorOutputs")  \
  X(rejuv_msg_Setpoint, "rejuv::msg::Setpoint")                \
  X(rejuv_msg_MissionWaypoints, "rejuv::msg::MissionWaypoints") \
  X(rejuv_msg_SrMode, "rejuv::msg::SrMode")                    \
  X(rejuv_msg_RollbackSignal, "rejuv::msg::RollbackSignal")    \
  X(rejuv_msg_SetpointUpdateRequest, "rejuv::msg::SetpointUpdateRequest") \
  X(rejuv_msg_SecurityEvent, "rejuv::msg::SecurityEvent")      \
  X(rejuv_msg_SimStep, "rejuv::msg::SimStep")                  \
  X(rejuv_msg_SimStepAck, "rejuv::msg::SimStepAck")

namespace rejuv::msgs {

struct TopicType {
  std::string_view name;                       // IDL scoped name, as written in policies
  std::size_t size;                            // sizeof the C struct: every payload has exactly this size
  std::size_t align;
  const dds_topic_descriptor_t* descriptor;    // for Cyclone DDS
};

[[nodiscard]] std::span<const TopicType> all_topic_types();
// nullptr when no topic type has that name.
[[nodiscard]] const TopicType* find_topic_type(std::string_view name);

// Compile-time name of a topic's C type: TopicTraits<rejuv_msg_SensorGyro>::name.
template <class T>
struct TopicTraits;

#define REJUV_TOPIC_TRAITS(CType, Name)                                           \
  template <>                                                                     \
  struct TopicTraits<CType> {                                                     \
    static constexpr std::string_view name = Name;                                \
    static const dds_topic_descriptor_t* descriptor() { return &CType##_desc; }   \
  };
REJUV_TOPIC_TYPES(REJUV_TOPIC_TRAITS)
#undef REJUV_TOPIC_TRAITS

}  // namespace rejuv::msgs

// A topic type of a service's own IDL (SDK rejuv_add_topics, docs/writing_a_service.md "A new topic type"),
// at namespace scope: REJUV_TOPIC_TYPE(hello_Summary, "hello::Summary"). The policy declares the name with
// the struct's size (`types`); advertise<>/subscribe<> check both. No DDS descriptor: not bridged.
#define REJUV_TOPIC_TYPE(CType, Name)                    \
  template <>                                            \
  struct rejuv::msgs::TopicTraits<CType> {               \
    static constexpr std::string_view name = Name;       \
  }
