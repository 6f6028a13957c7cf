// The DDS interface between the plant process and the kernel (DESIGN §2, §5, §6; the plant plays jMAVSim,
// a separate process over sockets, paper §VI-A). DDS topic names are "rejuv/<policy topic name>", the
// default of the launch graph's `dds.bridges` (idl/launch.proto, Bridge.dds_name).
//
// Lockstep protocol (DESIGN §6, docs/protocol.md "Lockstep with the plant"; the plant is the time master, as
// in PX4 lockstep):
//   1. Connect. The plant creates its readers, then its writers with sim_step last; the kernel creates its
//      bridged readers with sim_step last and its writers with sim_step_ack last. Each side then waits until
//      its endpoints of the protocol are matched (the plant: sim_step, sim_step_ack, actuator_outputs; the
//      kernel also its actuator_outputs and sim_step_ack writers) before writing anything: volatile samples
//      written before a match are lost.
//   2. Step k: the plant advances physics by the step period (plus the charged time of ack k−1) with the last
//      actuator outputs held (during its pre-flight alignment, --align-s, the vehicle rests at its start pose
//      and the outputs are not applied yet) and writes SimStep{k, time_ns, samples_published, …} with the
//      sensor samples due in that interval and the ground truth inside it (idl/sim.idl). Samples beyond what
//      the step holds (a long, charged step) are published on their own topics first; samples_published is
//      the running total of those.
//   3. DDS orders samples per writer only, so the kernel handles step k once it has received
//      samples_published samples on their topics: it routes the step's samples, runs the graph until every
//      service is idle, then writes SimStepAck{k, time_ns, charged_ns, outputs_published, outputs} with the
//      step's newest actuator outputs inside (older ones that did not fit went out on actuator_outputs;
//      outputs_published is their running total). charged_ns is the real time spent in checkpoint/rollback,
//      which the plant adds to simulated time with the motors held (the gaps of Fig. 7).
//   4. The plant applies the step once it has the ack and outputs_published outputs on their topic, then the
//      ack's own outputs. Nothing within its
//      --ack-timeout-ms means the kernel died: it exits with status 3, never hangs.
#pragma once

#include <string_view>

#include "rejuv/core/result.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::dds::plant_topics {

// A topic of the plant interface: DDS name and C struct.
template <class T>
struct Topic {
  using type = T;
  std::string_view name{};
};

inline constexpr Topic<rejuv_msg_SensorGyro> kSensorGyro{"rejuv/sensor_gyro"};
inline constexpr Topic<rejuv_msg_SensorAccel> kSensorAccel{"rejuv/sensor_accel"};
inline constexpr Topic<rejuv_msg_SensorMag> kSensorMag{"rejuv/sensor_mag"};
inline constexpr Topic<rejuv_msg_SensorBaro> kSensorBaro{"rejuv/sensor_baro"};
inline constexpr Topic<rejuv_msg_SensorGps> kSensorGps{"rejuv/sensor_gps"};
inline constexpr Topic<rejuv_msg_GroundTruth> kGroundTruth{"rejuv/ground_truth"};  // evaluation only
inline constexpr Topic<rejuv_msg_ActuatorOutputs> kActuatorOutputs{"rejuv/actuator_outputs"};
inline constexpr Topic<rejuv_msg_SimStep> kSimStep{"rejuv/sim_step"};
inline constexpr Topic<rejuv_msg_SimStepAck> kSimStepAck{"rejuv/sim_step_ack"};

// The msgs::TopicType of a plant topic (for Writer::create / Reader::create).
template <class T>
[[nodiscard]] const msgs::TopicType& type_of(Topic<T> /*topic*/) {
  const msgs::TopicType* type = msgs::find_topic_type(msgs::TopicTraits<T>::name);
  REJUV_ASSERT(type != nullptr, "every TopicTraits type is in the topic table");
  return *type;
}

}  // namespace rejuv::dds::plant_topics
