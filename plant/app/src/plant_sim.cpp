#include "rejuv/plant_app/plant_sim.hpp"

#include <algorithm>
#include <cstring>

#include "rejuv/core/result.hpp"
#include "rejuv/dds/plant_topics.hpp"

namespace rejuv::plant_app {

namespace {

// A message over zeroed bytes: its padding (SensorGps has 6 bytes after satellites_used) carries nothing of this
// process's memory into the kernel's routes and the ULog (`T m{}` need not zero padding).
template <typename T>
T blank() {
  T m;
  std::memset(&m, 0, sizeof m);
  return m;
}

// Different streams for sensors and wind from one seed (the splitmix64 increment keeps them apart).
constexpr std::uint64_t kWindSeedOffset = 0x9E3779B97F4A7C15ULL;
constexpr double kImuTemperature_c = 25.0;  // a warm IMU; the models have no thermal drift
constexpr double kIsaSeaLevel_c = 15.0;     // ISA temperature lapse for the baro's temperature
constexpr double kIsaLapse_c_per_m = 0.0065;
constexpr std::uint8_t kGpsFix3d = 3;
constexpr std::uint8_t kGpsSatellites = 10;

std::uint64_t stamp(Nanos t) {
  return static_cast<std::uint64_t>(t.count());
}

void copy3(double (&dst)[3], const Eigen::Vector3d& v) {
  dst[0] = v.x();
  dst[1] = v.y();
  dst[2] = v.z();
}

plant::QuadState initial_state(const PlantSimConfig& c) {
  return plant::Quadrotor::hover_at(plant::QuadParams::jmavsim_default(), c.start_N_m);
}

// One sample as the message its topic carries (flight_io/messages.hpp). The IMU's two: a body-frame vector
// and the IMU's temperature.
template <typename Msg>
Msg imu_message(Nanos t, double (Msg::*vector)[3], const Eigen::Vector3d& value) {
  auto m = blank<Msg>();
  m.timestamp_ns = stamp(t);
  copy3(m.*vector, value);
  m.temperature_c = kImuTemperature_c;
  return m;
}
rejuv_msg_SensorGyro message_of(const plant::GyroSample& g, const plant::SensorParams& /*sp*/) {
  return imu_message(g.t, &rejuv_msg_SensorGyro::omega_B_rad_s, g.omega_B_rad_s);
}
rejuv_msg_SensorAccel message_of(const plant::AccelSample& a, const plant::SensorParams& /*sp*/) {
  return imu_message(a.t, &rejuv_msg_SensorAccel::f_B_m_s2, a.f_B_m_s2);
}
rejuv_msg_SensorMag message_of(const plant::MagSample& b, const plant::SensorParams& /*sp*/) {
  auto m = blank<rejuv_msg_SensorMag>();
  m.timestamp_ns = stamp(b.t);
  copy3(m.b_B_gauss, b.b_B_gauss);
  return m;
}
rejuv_msg_SensorBaro message_of(const plant::BaroSample& b, const plant::SensorParams& sp) {
  auto m = blank<rejuv_msg_SensorBaro>();
  m.timestamp_ns = stamp(b.t);
  m.pressure_pa = b.pressure_pa;
  m.altitude_m = b.altitude_m;
  m.temperature_c = kIsaSeaLevel_c - kIsaLapse_c_per_m * (sp.home_altitude_amsl_m + b.altitude_m);
  return m;
}
rejuv_msg_SensorGps message_of(const plant::GpsSample& g, const plant::SensorParams& /*sp*/) {
  auto m = blank<rejuv_msg_SensorGps>();
  m.timestamp_ns = stamp(g.t);
  copy3(m.p_N_m, g.p_N_m);
  copy3(m.v_N_m_s, g.v_N_m_s);
  m.eph_m = g.eph_m;
  m.epv_m = g.epv_m;
  m.fix_type = kGpsFix3d;
  m.satellites_used = kGpsSatellites;
  return m;
}

// The messages of one sensor step, in the order the flight services expect them within a tick (gyro, accel,
// then the aiding sensors).
template <typename Emit>
void for_each_message(const plant::SensorSamples& s, const plant::SensorParams& sp, Emit&& emit) {
  const auto put = [&](const auto& sample) {
    if (sample) emit(message_of(*sample, sp));
  };
  put(s.gyro);
  put(s.accel);
  put(s.mag);
  put(s.baro);
  put(s.gps);
}

}  // namespace

void pack_step(const std::vector<SensorMessage>& batch, const rejuv_msg_GroundTruth& truth, rejuv_msg_SimStep& step,
               std::vector<SensorMessage>& overflow) {
  namespace topics = dds::plant_topics;  // the table the kernel unpacks the step with (plant_lockstep.hpp)
  topics::for_each_step_kind([&](std::size_t /*row*/, const auto& kind) { kind.clear(step); });
  for (const SensorMessage& m : batch) {
    const bool packed = std::visit(
        [&](const auto& sample) {
          return topics::step_kind_of<std::remove_cvref_t<decltype(sample)>>().put(step, sample);
        },
        m);
    if (!packed) overflow.push_back(m);
  }
  (void)topics::step_kind_of<rejuv_msg_GroundTruth>().put(step, truth);
}

PlantSim::PlantSim(const PlantSimConfig& config)
    : config_(config),
      quad_(plant::QuadParams::jmavsim_default(), initial_state(config)),
      sensors_(plant::SensorParams::defaults(), config.seed),
      wind_(config.wind, config.seed + kWindSeedOffset),
      motor_command_(Eigen::Vector4d::Constant(quad_.params().hover_level())) {
  REJUV_ASSERT(config.physics_period > Nanos{0}, "physics period > 0");
}

bool PlantSim::set_motor_command(const rejuv_msg_ActuatorOutputs& command) {
  const Eigen::Vector4d U(command.motor[0], command.motor[1], command.motor[2], command.motor[3]);
  if (!U.allFinite()) {
    return false;
  }
  motor_command_ = U;
  return true;
}

void PlantSim::advance(Nanos interval, std::vector<SensorMessage>& out) {
  REJUV_ASSERT(interval > Nanos{0}, "advance by a positive interval");
  const plant::SensorParams& sp = sensors_.params();
  Nanos remaining = interval;
  while (remaining > Nanos{0}) {
    const Nanos dt = std::min(config_.physics_period, remaining);
    // Aligning: held at rest (a = 0), as rejuv sim's alignment feeds its estimator (flight/sim sr_sim.cpp).
    const bool at_rest = aligning();
    if (!at_rest) {
      const Eigen::Vector3d wind_N = wind_.step(to_seconds(dt));
      quad_.step(to_seconds(dt), motor_command_, wind_N);
    }
    now_ += dt;
    remaining -= dt;
    const plant::SensorSamples s =
        sensors_.step(now_, quad_.state(), at_rest ? Eigen::Vector3d::Zero() : quad_.acceleration_N());
    for_each_message(s, sp, [&](const auto& m) { out.emplace_back(m); });
  }
}

rejuv_msg_GroundTruth PlantSim::ground_truth() const {
  const plant::QuadState& x = quad_.state();
  auto m = blank<rejuv_msg_GroundTruth>();
  m.timestamp_ns = stamp(now_);
  copy3(m.p_N_m, x.p_NB_N);
  copy3(m.v_N_m_s, x.v_NB_N);
  m.q_NB[0] = x.q_NB.w();
  m.q_NB[1] = x.q_NB.x();
  m.q_NB[2] = x.q_NB.y();
  m.q_NB[3] = x.q_NB.z();
  copy3(m.omega_B_rad_s, x.omega_B_rad_s);
  return m;
}

}  // namespace rejuv::plant_app
