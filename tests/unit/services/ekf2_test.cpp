// ekf2: the service's node, fed with the plant's own sensor messages (rejuv_plant_process), converges on a
// hovering vehicle and computes exactly what the simulation's estimator node computes from the same samples.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <variant>
#include <vector>

#include "rejuv/core/overloaded.hpp"
#include "rejuv/plant_app/plant_sim.hpp"
#include "rejuv/services/ekf2/ekf2_node.hpp"
#include "rejuv/services/sensors/imu_combiner.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;

const Eigen::Vector3d kStart_N_m(0, 0, -3);

flight::EkfState initial_state(const Eigen::Vector3d& p_N_m, double yaw_rad) {
  flight_io::MissionSpec m;
  m.waypoints = {flight::PathWaypoint{.p_N_m = p_N_m, .yaw_rad = yaw_rad}};
  return flight_io::ekf_initial_state(m);
}

// The plant (hovering, motors at the hover level) → sensors → ekf2, routed like the kernel does: the raw
// aiding samples of a tick reach ekf2 directly, the tick's sensor_combined after its detour through sensors.
class HoverChain {
 public:
  explicit HoverChain(const flight::EkfState& initial)
      : plant_(plant_app::PlantSimConfig{.seed = 7, .start_N_m = kStart_N_m}),
        combiner_(flight_io::imu_period(),
                  [this](const rejuv_msg_SensorCombined& m) { combined_.push_back(m); }),
        ekf2_(flight_io::ekf_params(), initial, flight_io::imu_period()) {}

  // One physics tick (1 ms). Calls `on_tick(samples)` with the tick's samples as the simulation sees them.
  template <class F>
  void tick(F&& on_tick) {
    batch_.clear();
    plant_.advance(milliseconds{1}, batch_);
    plant::SensorSamples samples;
    for (const plant_app::SensorMessage& message : batch_) {
      std::visit(Overloaded{
                     [&](const rejuv_msg_SensorGyro& m) {
                       samples.gyro = *flight_io::gyro_sample(m);
                       ASSERT_TRUE(combiner_.on_gyro(m));
                     },
                     [&](const rejuv_msg_SensorAccel& m) {
                       samples.accel = *flight_io::accel_sample(m);
                       ASSERT_TRUE(combiner_.on_accel(m));
                     },
                     [&](const rejuv_msg_SensorMag& m) {
                       samples.mag = *flight_io::mag_sample(m);
                       ASSERT_TRUE(ekf2_.on_mag(m));
                     },
                     [&](const rejuv_msg_SensorBaro& m) {
                       samples.baro = *flight_io::baro_sample(m);
                       ASSERT_TRUE(ekf2_.on_baro(m));
                     },
                     [&](const rejuv_msg_SensorGps& m) {
                       samples.gps = *flight_io::gps_sample(m);
                       ASSERT_TRUE(ekf2_.on_gps(m));
                     },
                     [](const auto&) {},  // a sensor the EKF does not fuse (the plant may have more)
                 },
                 message);
    }
    for (const rejuv_msg_SensorCombined& m : combined_) {
      auto out = ekf2_.on_combined(m);
      ASSERT_TRUE(out) << out.error().to_string();
      if (*out) published_ = **out;
    }
    combined_.clear();
    on_tick(samples);
  }

  [[nodiscard]] const plant_app::PlantSim& plant() const { return plant_; }
  [[nodiscard]] const std::optional<rejuv_msg_VehicleStateEstimate>& published() const { return published_; }

 private:
  plant_app::PlantSim plant_;
  ImuCombiner combiner_;
  Ekf2Node ekf2_;
  std::vector<plant_app::SensorMessage> batch_;
  std::vector<rejuv_msg_SensorCombined> combined_;
  std::optional<rejuv_msg_VehicleStateEstimate> published_;
};

TEST(Ekf2Node, Ekf2Node_HoverFromAWrongStart_ConvergesOnTheTruth) {
  // Given an estimator that starts 0.3 m and 0.1 rad of yaw away from where the vehicle hovers,
  HoverChain chain(initial_state(kStart_N_m + Eigen::Vector3d(0.3, -0.2, 0.15), 0.1));
  // when it has seen 20 s of the plant's sensors,
  for (int i = 0; i < 20'000; ++i) chain.tick([](const plant::SensorSamples&) {});
  // then the published estimate is the true state.
  ASSERT_TRUE(chain.published().has_value());
  const rejuv_msg_VehicleStateEstimate& m = *chain.published();
  const rejuv_msg_GroundTruth truth = chain.plant().ground_truth();
  auto x_hat = flight_io::state_from_message(m);
  ASSERT_TRUE(x_hat);
  const Eigen::Vector3d p_true(truth.p_N_m[0], truth.p_N_m[1], truth.p_N_m[2]);
  const Eigen::Vector3d v_true(truth.v_N_m_s[0], truth.v_N_m_s[1], truth.v_N_m_s[2]);
  const Eigen::Vector3d euler_true = flight::euler_from_quaternion(
      Eigen::Quaterniond(truth.q_NB[0], truth.q_NB[1], truth.q_NB[2], truth.q_NB[3]));
  EXPECT_LT((x_hat->segment<3>(flight::idx::kPos) - p_true).norm(), 0.1);
  EXPECT_LT((x_hat->segment<3>(flight::idx::kVel) - v_true).norm(), 0.1);
  EXPECT_LT((x_hat->segment<3>(flight::idx::kAtt) - euler_true).cwiseAbs().maxCoeff(), 0.03);
  EXPECT_NE(m.flags & flight_io::kStateAttitudeValid, 0U);
  EXPECT_NE(m.flags & flight_io::kStatePositionValid, 0U);
  EXPECT_EQ(m.timestamp_ns, truth.timestamp_ns - 3'000'000U) << "stamped with the last IMU tick (every 4 ms)";
}

TEST(Ekf2Node, Ekf2Node_SameSamples_SameEstimateAsTheSimulationsEstimatorNode) {
  const flight::EkfState start = initial_state(kStart_N_m, 0.0);
  HoverChain chain(start);
  flight::EstimatorNode reference(flight_io::ekf_params(), start, flight_io::imu_period());
  int ticks = 0;
  for (int i = 0; i < 3'000; ++i) {
    chain.tick([&](const plant::SensorSamples& samples) {
      if (!reference.on_samples(samples)) return;
      ++ticks;
      ASSERT_TRUE(chain.published().has_value());
      auto x_hat = flight_io::state_from_message(*chain.published());
      ASSERT_TRUE(x_hat);
      ASSERT_EQ(*x_hat, reference.estimate()) << "tick " << ticks << ": bit-identical x̂ expected";
    });
  }
  EXPECT_EQ(ticks, 750);
}

TEST(Ekf2Node, Ekf2Node_RollbackSignal_RearmsTheFilterAndDropsHeldSamples) {
  Ekf2Node node(flight_io::ekf_params(), initial_state(kStart_N_m, 0.0), flight_io::imu_period());
  rejuv_msg_SensorMag mag{};
  mag.b_B_gauss[0] = 0.2;
  mag.b_B_gauss[2] = 0.4;
  ASSERT_TRUE(node.on_mag(mag));
  const flight::EkfRearm rearm = *flight_io::ekf_rearm(flight_io::Params::from_table({}));
  node.on_rollback(rearm);
  EXPECT_DOUBLE_EQ(node.node().ekf().covariance()(0, 0), rearm.position_std_m * rearm.position_std_m);
  rejuv_msg_SensorCombined tick{};
  tick.timestamp_ns = 4'000'000;
  tick.f_B_m_s2[2] = -9.81;
  ASSERT_TRUE(node.on_combined(tick));
  const flight::EkfCounters& c = node.node().ekf().counters();
  EXPECT_EQ(c.mag_fused + c.mag_rejected, 0U) << "a sample held from before the cut is not fused after it";
}

TEST(Ekf2Node, Ekf2Node_NonFiniteMag_RefusedAndTheFilterUntouched) {
  Ekf2Node node(flight_io::ekf_params(), initial_state(kStart_N_m, 0.0), flight_io::imu_period());
  rejuv_msg_SensorMag m{};
  m.b_B_gauss[0] = std::numeric_limits<double>::infinity();
  const auto r = node.on_mag(m);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, flight_io::InputError::NotFinite);
  EXPECT_EQ(node.node().ekf().counters().mag_fused + node.node().ekf().counters().mag_rejected, 0U);
}

TEST(Ekf2Node, Ekf2Node_GpsWithoutA3dFix_Refused) {
  Ekf2Node node(flight_io::ekf_params(), initial_state(kStart_N_m, 0.0), flight_io::imu_period());
  rejuv_msg_SensorGps m{};
  m.fix_type = 2;
  const auto r = node.on_gps(m);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, flight_io::InputError::OutOfRange);
}

}  // namespace
}  // namespace rejuv::services
