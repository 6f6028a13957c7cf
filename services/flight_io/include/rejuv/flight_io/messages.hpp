// Conversions between the IDL topic types (idl/*.idl, C structs) and the vocabulary of the flight libraries
// (plant sample structs, the 12-state x, the input u). One place, so that every service reads a topic the way
// its publisher wrote it: a state or setpoint that crosses a topic comes back bit-identical, which keeps the
// multi-process runtime on the simulation's numbers.
//
// Messages from another process are untrusted: every decoder checks that the numbers are finite (a NaN in an
// estimator or a controller would poison it until the next rollback) and returns an InputFailure otherwise.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight/limits.hpp"
#include "rejuv/flight/output_driver.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/plant/sensor_samples.hpp"

namespace rejuv::flight_io {

// ---- time stamps (ns since the run started; a negative time is stamped 0) ----
[[nodiscard]] std::uint64_t stamp(Nanos t);
[[nodiscard]] Nanos time_of(std::uint64_t timestamp_ns);

// ---- raw sensors (plant → sensors, ekf2) ----
[[nodiscard]] Result<plant::GyroSample, InputFailure> gyro_sample(const rejuv_msg_SensorGyro& m);
[[nodiscard]] Result<plant::AccelSample, InputFailure> accel_sample(const rejuv_msg_SensorAccel& m);
[[nodiscard]] Result<plant::MagSample, InputFailure> mag_sample(const rejuv_msg_SensorMag& m);
[[nodiscard]] Result<plant::BaroSample, InputFailure> baro_sample(const rejuv_msg_SensorBaro& m);
// fix_type < 3 (no 3D fix) is refused as OutOfRange: the EKF fuses 3D positions only.
[[nodiscard]] Result<plant::GpsSample, InputFailure> gps_sample(const rejuv_msg_SensorGps& m);

// ---- sensor_combined (sensors → ekf2): one IMU tick ----
[[nodiscard]] rejuv_msg_SensorCombined combined_message(const plant::GyroSample& gyro,
                                                        const plant::AccelSample& accel, Seconds gyro_dt,
                                                        Seconds accel_dt);
struct ImuTick {
  plant::GyroSample gyro{};    // t = the tick's time stamp
  plant::AccelSample accel{};  // t = the tick's time stamp
};
[[nodiscard]] Result<ImuTick, InputFailure> imu_tick(const rejuv_msg_SensorCombined& m);

// ---- vehicle_state (ekf2 → controllers, gen_set_point, checkpoint_p) ----
// Bits of VehicleStateEstimate.flags (idl/state.idl).
inline constexpr std::uint32_t kStateAttitudeValid = 1U << 0U;
inline constexpr std::uint32_t kStatePositionValid = 1U << 1U;
inline constexpr std::uint32_t kStateInnovationRejected = 1U << 2U;
inline constexpr std::uint32_t kStateCatchUpDiscarded = 1U << 3U;  // docs/control.md §6.3
[[nodiscard]] rejuv_msg_VehicleStateEstimate vehicle_state_message(const flight::EstimatorNode& node, Nanos t,
                                                                   std::uint32_t flags);
// x̂ exactly as EstimatorNode::estimate() formed it: [p̂, v̂, euler(q̂), ω corrected].
[[nodiscard]] Result<flight::StateVec, InputFailure> state_from_message(
    const rejuv_msg_VehicleStateEstimate& m);

// ---- setpoint (gen_set_point → controllers, checkpoint_p) ----
// x_sp is a hover state (position and yaw, the rest 0), so (p, ψ) carries it exactly.
[[nodiscard]] rejuv_msg_Setpoint setpoint_message(const flight::StateVec& x_sp, Nanos t,
                                                  std::uint32_t waypoint_index, bool mission_done);
[[nodiscard]] Result<flight::StateVec, InputFailure> setpoint_from_message(const rejuv_msg_Setpoint& m);

// ---- actuator_controls (lqr_control, safety_control → output_driver) ----
[[nodiscard]] rejuv_msg_ActuatorControls controls_message(const flight::InputVec& u, Nanos t, Epoch epoch);
[[nodiscard]] Result<flight::InputVec, InputFailure> controls_from_message(
    const rejuv_msg_ActuatorControls& m);

// ---- actuator_limits (checkpoint_p → the kernel's Limits object → output_driver; docs/design.md §3, §IV-C) ----
// The bytes of a LimitsWrite (and what LimitsRead returns): one fixed-size record in the host's layout (the
// kernel stores the bytes, it never interprets them). u = [F N, τφ N·m, τθ N·m, τψ N·m].
inline constexpr std::uint32_t kLimitsRecordVersion = 1;
struct LimitsRecord {
  std::uint32_t version = kLimitsRecordVersion;
  std::uint32_t restricted = 0;  // 1: the restricted limits Ū (MC), 0: the full limits U
  double lo[4] = {};
  double hi[4] = {};
};
static_assert(std::is_trivially_copyable_v<LimitsRecord>);
[[nodiscard]] LimitsRecord limits_record(const flight::InputBox& box, flight::LimitSet set);
[[nodiscard]] std::array<std::byte, sizeof(LimitsRecord)> limits_bytes(const LimitsRecord& record);
struct DecodedLimits {
  flight::InputBox box{};
  flight::LimitSet set = flight::LimitSet::Full;
};
// Exactly sizeof(LimitsRecord) bytes, the known version, restricted ∈ {0, 1}, finite, lo ≤ hi.
[[nodiscard]] Result<DecodedLimits, InputFailure> limits_from_bytes(std::span<const std::byte> data);

// ---- sr_mode (the kernel, on every transition) ----
[[nodiscard]] Result<SrMode, InputFailure> mode_from_message(const rejuv_msg_SrMode& m);

// ---- mission (commander → gen_set_point; ext_link → commander as mission_upload) ----
// Precondition: at most kMaxWaypoints waypoints (mission_params and mission_from_message guarantee it).
[[nodiscard]] rejuv_msg_MissionWaypoints mission_message(const MissionSpec& mission, Nanos t);
// 1 ≤ count ≤ 16, finite waypoints, acceptance radius finite and > 0.
[[nodiscard]] Result<MissionSpec, InputFailure> mission_from_message(const rejuv_msg_MissionWaypoints& m);

}  // namespace rejuv::flight_io
