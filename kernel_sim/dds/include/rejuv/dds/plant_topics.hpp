// The DDS interface between the plant process and the kernel (docs/design.md §2, §5, §6; the plant plays jMAVSim,
// a separate process over sockets, paper §VI-A). DDS topic names are "rejuv/<policy topic name>", the
// default of the launch graph's `dds.bridges` (idl/launch.proto, Bridge.dds_name).
//
// Lockstep protocol (docs/design.md §6, docs/protocol.md "Lockstep with the plant"; the plant is the time master, as
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
//
// Both ends pack and unpack a step's samples through one table, kStepSamples below (docs/conventions.md: one protocol,
// one codec): the plant (plant_app pack_step) and the kernel (plant_lockstep.hpp) name no sensor themselves.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <variant>

#include "rejuv/core/dds_name.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/msgs/dds_naming.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::dds::plant_topics {

// A topic of the plant interface: DDS name and C struct.
template <class T>
struct Topic {
  using type = T;
  std::string_view name{};
};

// Their DDS names: kDdsNamePrefix and the policy topic's name (rejuv/core/dds_name.hpp).
namespace dds_names {
inline constexpr DdsName kSensorGyro{"sensor_gyro"};
inline constexpr DdsName kSensorAccel{"sensor_accel"};
inline constexpr DdsName kSensorMag{"sensor_mag"};
inline constexpr DdsName kSensorBaro{"sensor_baro"};
inline constexpr DdsName kSensorGps{"sensor_gps"};
inline constexpr DdsName kGroundTruth{"ground_truth"};
inline constexpr DdsName kActuatorOutputs{"actuator_outputs"};
inline constexpr DdsName kSimStep{"sim_step"};
inline constexpr DdsName kSimStepAck{"sim_step_ack"};
}  // namespace dds_names

inline constexpr Topic<rejuv_msg_SensorGyro> kSensorGyro{dds_names::kSensorGyro.view()};
inline constexpr Topic<rejuv_msg_SensorAccel> kSensorAccel{dds_names::kSensorAccel.view()};
inline constexpr Topic<rejuv_msg_SensorMag> kSensorMag{dds_names::kSensorMag.view()};
inline constexpr Topic<rejuv_msg_SensorBaro> kSensorBaro{dds_names::kSensorBaro.view()};
inline constexpr Topic<rejuv_msg_SensorGps> kSensorGps{dds_names::kSensorGps.view()};
inline constexpr Topic<rejuv_msg_GroundTruth> kGroundTruth{dds_names::kGroundTruth.view()};  // evaluation only
inline constexpr Topic<rejuv_msg_ActuatorOutputs> kActuatorOutputs{dds_names::kActuatorOutputs.view()};
inline constexpr Topic<rejuv_msg_SimStep> kSimStep{dds_names::kSimStep.view()};
inline constexpr Topic<rejuv_msg_SimStepAck> kSimStepAck{dds_names::kSimStepAck.view()};

// A sample a step may carry: a fixed-size struct whose first member is `uint64 timestamp_ns` (the kernel stages
// bridged samples by their first 8 bytes: kernel_sim/kernel/src/lockstep.cpp, stage_sample), checked here so
// that a new sensor's IDL cannot get it wrong silently.
template <class T>
concept StampedSample = std::is_standard_layout_v<T> && std::is_trivially_copyable_v<T> &&
                        std::is_same_v<decltype(T::timestamp_ns), std::uint64_t> && offsetof(T, timestamp_ns) == 0;

// The timestamp of a bridged sample from its bytes, its first 8 (StampedSample); none if it is shorter.
[[nodiscard]] inline std::optional<std::uint64_t> stamp_of(std::span<const std::byte> sample) {
  std::uint64_t stamp = 0;
  if (sample.size() < sizeof(stamp)) return std::nullopt;
  std::memcpy(&stamp, sample.data(), sizeof(stamp));
  return stamp;
}

// Samples of type T that a SimStep carries in an array with a count of valid entries (oldest first).
template <StampedSample T, std::size_t N>
struct StepArray {
  Topic<T> topic;  // where the samples go when the step cannot hold them (and what the kernel bridges in)
  T (rejuv_msg_SimStep::*array)[N];
  std::uint8_t rejuv_msg_SimStep::*count;

  [[nodiscard]] std::span<const T> samples(const rejuv_msg_SimStep& step) const {
    return std::span<const T>(step.*array, std::min<std::size_t>(step.*count, N));
  }
  void clear(rejuv_msg_SimStep& step) const { step.*count = 0; }
  // Appends `sample`; false when the array is full (the sample goes out on its own topic).
  bool put(rejuv_msg_SimStep& step, const T& sample) const {
    if (step.*count >= N) return false;
    (step.*array)[step.*count] = sample;
    ++(step.*count);
    return true;
  }
};

// One sample of type T that every SimStep carries (the ground truth at the step's end).
template <StampedSample T>
struct StepValue {
  Topic<T> topic;
  T rejuv_msg_SimStep::*value;

  [[nodiscard]] std::span<const T> samples(const rejuv_msg_SimStep& step) const { return {&(step.*value), 1}; }
  void clear(rejuv_msg_SimStep& /*step*/) const {}
  bool put(rejuv_msg_SimStep& step, const T& sample) const {
    step.*value = sample;
    return true;
  }
};

// Deduction guides, spelled out: clang 16 (the fuzz build) does not deduce an aggregate's template arguments.
template <StampedSample T, std::size_t N>
StepArray(Topic<T>, T (rejuv_msg_SimStep::*)[N], std::uint8_t rejuv_msg_SimStep::*) -> StepArray<T, N>;
template <StampedSample T>
StepValue(Topic<T>, T rejuv_msg_SimStep::*) -> StepValue<T>;

// Every kind of sample a SimStep carries, in the order the kernel stages them (idl/sim.idl). For the protocol, a
// new sensor that rides on the step is its IDL (a struct in idl/sensors.idl, listed in REJUV_TOPIC_TYPES; its
// array and count in SimStep) and one row here: neither the plant's packing and publishing, nor its message
// type (SensorSample below), nor the kernel's adapter names a sensor. The plant still has to measure it
// (plant/, plant_app::PlantSim::advance); the whole recipe: docs/protocol.md "A new plant sensor".
inline constexpr auto kStepSamples = std::tuple{
    StepArray{kSensorGyro, &rejuv_msg_SimStep::gyro, &rejuv_msg_SimStep::gyro_count},
    StepArray{kSensorAccel, &rejuv_msg_SimStep::accel, &rejuv_msg_SimStep::accel_count},
    StepArray{kSensorMag, &rejuv_msg_SimStep::mag, &rejuv_msg_SimStep::mag_count},
    StepArray{kSensorBaro, &rejuv_msg_SimStep::baro, &rejuv_msg_SimStep::baro_count},
    StepArray{kSensorGps, &rejuv_msg_SimStep::gps, &rejuv_msg_SimStep::gps_count},
    StepValue{kGroundTruth, &rejuv_msg_SimStep::ground_truth},
};
inline constexpr std::size_t kStepSampleKinds = std::tuple_size_v<decltype(kStepSamples)>;

namespace detail {
// std::variant of the sample types of the StepArray rows of Rows..., in order (StepValue rows left out).
template <class Variant, class... Rows>
struct SensorVariant {
  using type = Variant;
};
template <class... Ts, class T, std::size_t N, class... Rows>
struct SensorVariant<std::variant<Ts...>, StepArray<T, N>, Rows...> : SensorVariant<std::variant<Ts..., T>, Rows...> {};
template <class... Ts, class T, class... Rows>
struct SensorVariant<std::variant<Ts...>, StepValue<T>, Rows...> : SensorVariant<std::variant<Ts...>, Rows...> {};
template <class Table>
struct SensorVariantOf;
template <class... Rows>
struct SensorVariantOf<std::tuple<Rows...>> : SensorVariant<std::variant<>, Rows...> {};
}  // namespace detail

// One sensor sample as the plant produces and publishes it: an alternative per StepArray row of kStepSamples
// (the ground truth, a StepValue, is not a sensor's). The plant's SensorMessage.
using SensorSample = typename detail::SensorVariantOf<std::remove_cvref_t<decltype(kStepSamples)>>::type;

// Calls f(row, entry) for each row of kStepSamples, in order (row: its index).
template <class F>
constexpr void for_each_step_kind(F&& f) {
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    (f(I, std::get<I>(kStepSamples)), ...);
  }(std::make_index_sequence<kStepSampleKinds>{});
}

// The row of kStepSamples whose samples are of type T (one row per type), and the row itself.
template <class T>
[[nodiscard]] consteval std::size_t step_row_of() {
  constexpr std::size_t row = [] {
    std::size_t found = kStepSampleKinds;
    for_each_step_kind([&](std::size_t i, const auto& kind) {
      if (std::is_same_v<typename std::remove_cvref_t<decltype(kind.topic)>::type, T>) found = i;
    });
    return found;
  }();
  static_assert(row < kStepSampleKinds, "T is not a sample a SimStep carries (kStepSamples)");
  return row;
}
template <class T>
[[nodiscard]] constexpr const auto& step_kind_of() {
  return std::get<step_row_of<T>()>(kStepSamples);
}

// How many samples `step` carries in all, by the table (its arrays' valid entries, clamped, and the ground
// truth): what a reader of SimSteps counts without naming a sensor.
[[nodiscard]] inline std::size_t samples_in(const rejuv_msg_SimStep& step) {
  std::size_t n = 0;
  for_each_step_kind([&](std::size_t /*row*/, const auto& kind) { n += kind.samples(step).size(); });
  return n;
}

// The msgs::TopicType of a plant topic (for Writer::create / Reader::create).
template <class T>
[[nodiscard]] const msgs::TopicType& type_of(Topic<T> /*topic*/) {
  const msgs::TopicType* type = msgs::find_topic_type(msgs::TopicTraits<T>::name);
  REJUV_ASSERT(type != nullptr, "every TopicTraits type is in the topic table");
  return *type;
}

// A plant topic as DDS names it under `naming` (rejuv/msgs/dds_naming.hpp): "rejuv/sensor_gyro" or, with ROS 2
// names, "rt/sensor_gyro" of type rejuv_msgs::msg::dds_::SensorGyro_. The kernel's bridge and the plant name
// every topic of the interface this way, so that both ends agree whatever the graph's dds.ros2_names.
template <class T>
[[nodiscard]] msgs::DdsTopic dds_topic(Topic<T> topic, DdsNaming naming) {
  REJUV_ASSERT(topic.name.starts_with(kDdsNamePrefix), "a plant topic's name is kDdsNamePrefix + its topic");
  return msgs::dds_topic(topic.name.substr(kDdsNamePrefix.size()), type_of(topic), naming);
}

}  // namespace rejuv::dds::plant_topics
