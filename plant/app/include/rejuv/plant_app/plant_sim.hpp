// The simulated world of the plant process, without any I/O (docs/design.md §9): the quadrotor (RK4, 1 kHz ticks),
// its sensor suite and the wind, advanced by whole intervals with the last motor command held, producing the
// DDS messages of the sensor samples due in each interval. Deterministic for a seed.
#pragma once

#include <cstdint>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "rejuv/core/time.hpp"
#include "rejuv/dds/plant_topics.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/plant/plant.hpp"

namespace rejuv::plant_app {

struct PlantSimConfig {
  std::uint64_t seed = 1;
  Eigen::Vector3d start_N_m = Eigen::Vector3d(0, 0, -3);  // trimmed hover here (QuadState hover_at)
  plant::WindParams wind{};
  Nanos physics_period{std::chrono::milliseconds{1}};  // 1 kHz (docs/design.md §9)
  // Pre-flight alignment (docs/control.md): for [0, alignment) the vehicle rests at its start pose (no
  // physics, no wind, motor commands stored but not applied) while the sensors keep sampling it, so that the
  // estimator converges before the flight starts, as `rejuv sim` aligns before its t = 0.
  Nanos alignment{0};
};

// One sensor message as published on DDS: an alternative per sensor of the step table (plant_topics.hpp,
// kStepSamples), so that a new sensor is not listed here too.
using SensorMessage = dds::plant_topics::SensorSample;

// Packs the sensor messages of one lockstep step (in `batch`, in order) and the ground truth into a SimStep
// (idl/sim.idl): each kind fills its array oldest first; what does not fit is appended to `overflow`, in
// order, to be published on its own topic before the step. `step.step`, `time_ns` and `samples_published`
// are left for the caller. Every array count of `step` starts from zero.
void pack_step(const std::vector<SensorMessage>& batch, const rejuv_msg_GroundTruth& truth, rejuv_msg_SimStep& step,
               std::vector<SensorMessage>& overflow);

class PlantSim {
 public:
  explicit PlantSim(const PlantSimConfig& config);

  // Holds U until the next command. A command with a non-finite entry is refused (false) and the previous one
  // kept: the plant is the outside world and takes no NaN from anyone. Values outside [0, 1] are clamped by
  // the rotor model.
  [[nodiscard]] bool set_motor_command(const rejuv_msg_ActuatorOutputs& command);

  // Advances simulated time by `interval` (> 0) in physics ticks (the last one shorter when the interval is
  // not a multiple of the period), appending to `out` every sensor message delivered during it, in order.
  void advance(Nanos interval, std::vector<SensorMessage>& out);

  [[nodiscard]] Nanos now() const { return now_; }
  [[nodiscard]] bool aligning() const { return now_ < config_.alignment; }
  [[nodiscard]] rejuv_msg_GroundTruth ground_truth() const;
  [[nodiscard]] const plant::Quadrotor& quadrotor() const { return quad_; }
  [[nodiscard]] const Eigen::Vector4d& motor_command() const { return motor_command_; }

 private:
  PlantSimConfig config_;
  plant::Quadrotor quad_;
  plant::SensorSuite sensors_;
  plant::Wind wind_;
  Eigen::Vector4d motor_command_;
  Nanos now_{0};
};

}  // namespace rejuv::plant_app
