#include "rejuv/flight_io/messages.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>

namespace rejuv::flight_io {

namespace {

Eigen::Vector3d vec3(const double (&a)[3]) {
  return {a[0], a[1], a[2]};
}

void copy3(double (&dst)[3], const Eigen::Vector3d& v) {
  dst[0] = v.x();
  dst[1] = v.y();
  dst[2] = v.z();
}

bool all_finite(std::initializer_list<double> values) {
  for (const double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}
bool all_finite(const double (&a)[3]) {
  return all_finite({a[0], a[1], a[2]});
}

InputFailure not_finite(std::string where) {
  return InputFailure{
      .kind = InputError::NotFinite, .where = std::move(where), .message = "expected finite numbers"};
}

constexpr std::uint8_t kGpsFix3d = 3;

}  // namespace

std::uint64_t stamp(Nanos t) {
  return t.count() < 0 ? 0U : static_cast<std::uint64_t>(t.count());
}

Nanos time_of(std::uint64_t timestamp_ns) {
  // A stamp past the range of Nanos (≈292 years) is not a time of this run: it saturates.
  constexpr auto kMax = static_cast<std::uint64_t>(Nanos::max().count());
  return Nanos{static_cast<Nanos::rep>(timestamp_ns > kMax ? kMax : timestamp_ns)};
}

// ---- raw sensors ----

Result<plant::GyroSample, InputFailure> gyro_sample(const rejuv_msg_SensorGyro& m) {
  if (!all_finite(m.omega_B_rad_s)) return fail(not_finite("sensor_gyro.omega_B_rad_s"));
  return plant::GyroSample{.t = time_of(m.timestamp_ns), .omega_B_rad_s = vec3(m.omega_B_rad_s)};
}

Result<plant::AccelSample, InputFailure> accel_sample(const rejuv_msg_SensorAccel& m) {
  if (!all_finite(m.f_B_m_s2)) return fail(not_finite("sensor_accel.f_B_m_s2"));
  return plant::AccelSample{.t = time_of(m.timestamp_ns), .f_B_m_s2 = vec3(m.f_B_m_s2)};
}

Result<plant::MagSample, InputFailure> mag_sample(const rejuv_msg_SensorMag& m) {
  if (!all_finite(m.b_B_gauss)) return fail(not_finite("sensor_mag.b_B_gauss"));
  return plant::MagSample{.t = time_of(m.timestamp_ns), .b_B_gauss = vec3(m.b_B_gauss)};
}

Result<plant::BaroSample, InputFailure> baro_sample(const rejuv_msg_SensorBaro& m) {
  if (!all_finite({m.altitude_m, m.pressure_pa})) return fail(not_finite("sensor_baro"));
  return plant::BaroSample{
      .t = time_of(m.timestamp_ns), .altitude_m = m.altitude_m, .pressure_pa = m.pressure_pa};
}

Result<plant::GpsSample, InputFailure> gps_sample(const rejuv_msg_SensorGps& m) {
  if (!all_finite(m.p_N_m) || !all_finite(m.v_N_m_s) || !all_finite({m.eph_m, m.epv_m})) {
    return fail(not_finite("sensor_gps"));
  }
  if (m.fix_type < kGpsFix3d) {
    return fail(InputFailure{.kind = InputError::OutOfRange,
                             .where = "sensor_gps.fix_type",
                             .message = "no 3D fix (fix_type " + std::to_string(m.fix_type) + ")"});
  }
  return plant::GpsSample{.t = time_of(m.timestamp_ns),
                          .p_N_m = vec3(m.p_N_m),
                          .v_N_m_s = vec3(m.v_N_m_s),
                          .eph_m = m.eph_m,
                          .epv_m = m.epv_m};
}

// ---- sensor_combined ----

rejuv_msg_SensorCombined combined_message(const plant::GyroSample& gyro, const plant::AccelSample& accel,
                                          Seconds gyro_dt, Seconds accel_dt) {
  rejuv_msg_SensorCombined m{};
  m.timestamp_ns = stamp(gyro.t);
  copy3(m.omega_B_rad_s, gyro.omega_B_rad_s);
  copy3(m.f_B_m_s2, accel.f_B_m_s2);
  m.gyro_dt_s = gyro_dt.count();
  m.accel_dt_s = accel_dt.count();
  return m;
}

Result<ImuTick, InputFailure> imu_tick(const rejuv_msg_SensorCombined& m) {
  if (!all_finite(m.omega_B_rad_s) || !all_finite(m.f_B_m_s2)) return fail(not_finite("sensor_combined"));
  const Nanos t = time_of(m.timestamp_ns);
  return ImuTick{.gyro = {.t = t, .omega_B_rad_s = vec3(m.omega_B_rad_s)},
                 .accel = {.t = t, .f_B_m_s2 = vec3(m.f_B_m_s2)}};
}

// ---- vehicle_state ----

rejuv_msg_VehicleStateEstimate vehicle_state_message(const flight::EstimatorNode& node, Nanos t,
                                                     std::uint32_t flags) {
  const flight::EkfState& s = node.ekf().state();
  const flight::StateVec& x_hat = node.estimate();
  const flight::Ekf::Covariance& P = node.ekf().covariance();
  rejuv_msg_VehicleStateEstimate m{};
  m.timestamp_ns = stamp(t);
  copy3(m.p_N_m, s.p_N_m);
  copy3(m.v_N_m_s, s.v_N_m_s);
  m.q_NB[0] = s.q_NB.w();
  m.q_NB[1] = s.q_NB.x();
  m.q_NB[2] = s.q_NB.y();
  m.q_NB[3] = s.q_NB.z();
  copy3(m.omega_B_rad_s, x_hat.segment<3>(flight::idx::kRate));
  copy3(m.gyro_bias_rad_s, s.gyro_bias_rad_s);
  copy3(m.accel_bias_m_s2, s.accel_bias_m_s2);
  copy3(m.variance_p_m2, P.diagonal().segment<3>(0));  // error-state order: δp, δv, δθ, δb_g, δb_a
  copy3(m.variance_v_m2_s2, P.diagonal().segment<3>(3));
  m.flags = flags;
  return m;
}

Result<flight::StateVec, InputFailure> state_from_message(const rejuv_msg_VehicleStateEstimate& m) {
  if (!all_finite(m.p_N_m) || !all_finite(m.v_N_m_s) || !all_finite(m.omega_B_rad_s) ||
      !all_finite({m.q_NB[0], m.q_NB[1], m.q_NB[2], m.q_NB[3]})) {
    return fail(not_finite("vehicle_state"));
  }
  const Eigen::Quaterniond q_NB(m.q_NB[0], m.q_NB[1], m.q_NB[2], m.q_NB[3]);
  if (!(q_NB.norm() > 0.5)) {  // a unit quaternion travels as one; anything near 0 is not an attitude
    return fail(InputFailure{.kind = InputError::OutOfRange,
                             .where = "vehicle_state.q_NB",
                             .message = "expected a unit quaternion"});
  }
  // The same expression as EstimatorNode::refresh_estimate, on the same numbers.
  return flight::make_state(vec3(m.p_N_m), vec3(m.v_N_m_s), flight::euler_from_quaternion(q_NB),
                            vec3(m.omega_B_rad_s));
}

// ---- setpoint ----

rejuv_msg_Setpoint setpoint_message(const flight::StateVec& x_sp, Nanos t, std::uint32_t waypoint_index,
                                    bool mission_done) {
  rejuv_msg_Setpoint m{};
  m.timestamp_ns = stamp(t);
  copy3(m.p_N_m, x_sp.segment<3>(flight::idx::kPos));
  m.yaw_rad = x_sp[flight::idx::kYaw];
  m.waypoint_index = waypoint_index;
  m.mission_done = mission_done ? 1 : 0;
  return m;
}

Result<flight::StateVec, InputFailure> setpoint_from_message(const rejuv_msg_Setpoint& m) {
  if (!all_finite(m.p_N_m) || !std::isfinite(m.yaw_rad)) return fail(not_finite("setpoint"));
  return flight::hover_setpoint(vec3(m.p_N_m), m.yaw_rad);
}

// ---- actuator_controls ----

rejuv_msg_ActuatorControls controls_message(const flight::InputVec& u, Nanos t, Epoch epoch) {
  rejuv_msg_ActuatorControls m{};
  m.timestamp_ns = stamp(t);
  m.thrust_N = u[flight::idx::kThrust];
  m.torque_B_N_m[0] = u[1];
  m.torque_B_N_m[1] = u[2];
  m.torque_B_N_m[2] = u[3];
  m.epoch = epoch.value();
  return m;
}

Result<flight::InputVec, InputFailure> controls_from_message(const rejuv_msg_ActuatorControls& m) {
  if (!all_finite({m.thrust_N, m.torque_B_N_m[0], m.torque_B_N_m[1], m.torque_B_N_m[2]})) {
    return fail(not_finite("actuator_controls"));
  }
  flight::InputVec u;
  u << m.thrust_N, m.torque_B_N_m[0], m.torque_B_N_m[1], m.torque_B_N_m[2];
  return u;
}

// ---- sr_mode ----

// ---- actuator_limits ----

LimitsRecord limits_record(const flight::InputBox& box, flight::LimitSet set) {
  LimitsRecord r{};
  r.restricted = set == flight::LimitSet::Restricted ? 1U : 0U;
  for (Eigen::Index i = 0; i < 4; ++i) {
    r.lo[i] = box.lo[i];
    r.hi[i] = box.hi[i];
  }
  return r;
}

std::array<std::byte, sizeof(LimitsRecord)> limits_bytes(const LimitsRecord& record) {
  std::array<std::byte, sizeof(LimitsRecord)> out{};
  std::memcpy(out.data(), &record, sizeof record);
  return out;
}

Result<DecodedLimits, InputFailure> limits_from_bytes(std::span<const std::byte> data) {
  const auto bad = [](InputError kind, std::string message) {
    return fail(InputFailure{.kind = kind, .where = "actuator_limits", .message = std::move(message)});
  };
  if (data.size() != sizeof(LimitsRecord)) {
    return bad(InputError::OutOfRange, "expected " + std::to_string(sizeof(LimitsRecord)) + " bytes, got " +
                                           std::to_string(data.size()));
  }
  LimitsRecord r{};
  std::memcpy(&r, data.data(), sizeof r);
  if (r.version != kLimitsRecordVersion) {
    return bad(InputError::OutOfRange, "unknown record version " + std::to_string(r.version));
  }
  if (r.restricted > 1U) return bad(InputError::OutOfRange, "restricted must be 0 or 1");
  DecodedLimits d{.box = {},
                  .set = r.restricted == 1U ? flight::LimitSet::Restricted : flight::LimitSet::Full};
  for (Eigen::Index i = 0; i < 4; ++i) {
    if (!all_finite({r.lo[i], r.hi[i]})) return bad(InputError::NotFinite, "limits must be finite");
    if (!(r.lo[i] <= r.hi[i])) return bad(InputError::OutOfRange, "lo must not exceed hi");
    d.box.lo[i] = r.lo[i];
    d.box.hi[i] = r.hi[i];
  }
  return d;
}

Result<SrMode, InputFailure> mode_from_message(const rejuv_msg_SrMode& m) {
  // The field's bytes as an integer first: a value outside the enumeration is bad input, and reading it as
  // the enumeration would already be undefined behaviour.
  std::uint32_t raw = 0;
  static_assert(sizeof(m.mode) == sizeof(raw));
  std::memcpy(&raw, &m.mode, sizeof(raw));
  const auto is = [raw](rejuv_msg_SrModeKind k) { return raw == static_cast<std::uint32_t>(k); };
  if (is(rejuv_msg_SR_MODE_MC)) return SrMode::MC;
  if (is(rejuv_msg_SR_MODE_RB)) return SrMode::RB;
  if (is(rejuv_msg_SR_MODE_SC)) return SrMode::SC;
  if (is(rejuv_msg_SR_MODE_UPDATE)) return SrMode::Update;
  if (is(rejuv_msg_SR_MODE_CP)) return SrMode::CP;
  return fail(InputFailure{.kind = InputError::OutOfRange,
                           .where = "sr_mode.mode",
                           .message = "not a mode of Fig. 1: " + std::to_string(raw)});
}

// ---- mission ----

rejuv_msg_MissionWaypoints mission_message(const MissionSpec& mission, Nanos t) {
  REJUV_ASSERT(!mission.waypoints.empty() && mission.waypoints.size() <= kMaxWaypoints,
               "a mission message holds 1 to 16 waypoints (checked by mission_params)");
  rejuv_msg_MissionWaypoints m{};
  m.timestamp_ns = stamp(t);
  m.count = static_cast<std::uint32_t>(mission.waypoints.size());
  for (std::size_t i = 0; i < mission.waypoints.size(); ++i) {
    copy3(m.waypoints[i].p_N_m, mission.waypoints[i].p_N_m);
    m.waypoints[i].yaw_rad = mission.waypoints[i].yaw_rad;
  }
  m.acceptance_radius_m = mission.acceptance_radius_m;
  return m;
}

Result<MissionSpec, InputFailure> mission_from_message(const rejuv_msg_MissionWaypoints& m) {
  if (m.count < 1 || m.count > kMaxWaypoints) {
    return fail(InputFailure{.kind = InputError::OutOfRange,
                             .where = "mission.count",
                             .message = "expected 1 to " + std::to_string(kMaxWaypoints) +
                                        " waypoints, got " + std::to_string(m.count)});
  }
  if (!std::isfinite(m.acceptance_radius_m) || !(m.acceptance_radius_m > 0.0)) {
    return fail(InputFailure{.kind = InputError::OutOfRange,
                             .where = "mission.acceptance_radius_m",
                             .message = "expected a finite radius > 0 m"});
  }
  MissionSpec spec{.waypoints = {}, .acceptance_radius_m = m.acceptance_radius_m, .from_defaults = false};
  for (std::uint32_t i = 0; i < m.count; ++i) {
    const rejuv_msg_Waypoint& w = m.waypoints[i];
    if (!all_finite(w.p_N_m) || !std::isfinite(w.yaw_rad)) {
      return fail(not_finite("mission.waypoints[" + std::to_string(i) + "]"));
    }
    spec.waypoints.push_back(flight::PathWaypoint{.p_N_m = vec3(w.p_N_m), .yaw_rad = w.yaw_rad});
  }
  return spec;
}

}  // namespace rejuv::flight_io
