// sensors: a gyro + accel pair of one IMU tick becomes one sensor_combined with the right intervals.
#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "rejuv/services/sensors/imu_combiner.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;
constexpr Nanos kPeriod = milliseconds{4};

rejuv_msg_SensorGyro gyro_at(Nanos t, double wx) {
  rejuv_msg_SensorGyro m{};
  m.timestamp_ns = flight_io::stamp(t);
  m.omega_B_rad_s[0] = wx;
  m.omega_B_rad_s[1] = 0.02;
  m.omega_B_rad_s[2] = -0.03;
  return m;
}

rejuv_msg_SensorAccel accel_at(Nanos t, double fz) {
  rejuv_msg_SensorAccel m{};
  m.timestamp_ns = flight_io::stamp(t);
  m.f_B_m_s2[0] = 0.1;
  m.f_B_m_s2[1] = -0.2;
  m.f_B_m_s2[2] = fz;
  return m;
}

class ImuCombinerTest : public ::testing::Test {
 protected:
  ImuCombiner combiner_{kPeriod, [this](const rejuv_msg_SensorCombined& m) { out_.push_back(m); }};
  std::vector<rejuv_msg_SensorCombined> out_;
};

TEST_F(ImuCombinerTest, ImuCombiner_GyroThenAccel_OneCombinedWithBothSamples) {
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{1}, 0.5)));
  EXPECT_TRUE(out_.empty()) << "the tick is complete only with its accelerometer sample";
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{1}, -9.7)));
  ASSERT_EQ(out_.size(), 1U);
  const rejuv_msg_SensorCombined& m = out_[0];
  EXPECT_EQ(m.timestamp_ns, 1'000'000U);
  EXPECT_EQ(m.omega_B_rad_s[0], 0.5);
  EXPECT_EQ(m.omega_B_rad_s[1], 0.02);
  EXPECT_EQ(m.omega_B_rad_s[2], -0.03);
  EXPECT_EQ(m.f_B_m_s2[0], 0.1);
  EXPECT_EQ(m.f_B_m_s2[1], -0.2);
  EXPECT_EQ(m.f_B_m_s2[2], -9.7);
}

TEST_F(ImuCombinerTest, ImuCombiner_FirstTick_DtIsOneNominalPeriod) {
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{1}, 0)));
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{1}, -9.8)));
  ASSERT_EQ(out_.size(), 1U);
  EXPECT_DOUBLE_EQ(out_[0].gyro_dt_s, 0.004);
  EXPECT_DOUBLE_EQ(out_[0].accel_dt_s, 0.004);
}

TEST_F(ImuCombinerTest, ImuCombiner_NextTick_DtIsTheIntervalBetweenSamples) {
  for (const Nanos t :
       {Nanos{milliseconds{1}}, Nanos{milliseconds{5}}, Nanos{std::chrono::microseconds{8500}}}) {
    ASSERT_TRUE(combiner_.on_gyro(gyro_at(t, 0)));
    ASSERT_TRUE(combiner_.on_accel(accel_at(t, -9.8)));
  }
  ASSERT_EQ(out_.size(), 3U);
  EXPECT_DOUBLE_EQ(out_[1].gyro_dt_s, 0.004);
  EXPECT_DOUBLE_EQ(out_[1].accel_dt_s, 0.004);
  EXPECT_DOUBLE_EQ(out_[2].gyro_dt_s, 0.0035);
  EXPECT_DOUBLE_EQ(out_[2].accel_dt_s, 0.0035);
}

TEST_F(ImuCombinerTest, ImuCombiner_AccelBeforeGyro_PairsByTimeStamp) {
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{1}, -9.6)));
  EXPECT_TRUE(out_.empty());
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{1}, 0.25)));
  ASSERT_EQ(out_.size(), 1U);
  EXPECT_EQ(out_[0].omega_B_rad_s[0], 0.25);
  EXPECT_EQ(out_[0].f_B_m_s2[2], -9.6);
}

TEST_F(ImuCombinerTest, ImuCombiner_AccelSampleMissing_TickUsesTheHeldAccel) {
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{1}, 0)));
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{1}, -9.6)));
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{5}, 0.1)));  // its accel sample is lost
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{9}, 0.2)));
  ASSERT_EQ(out_.size(), 2U);
  EXPECT_EQ(out_[1].timestamp_ns, 5'000'000U);
  EXPECT_EQ(out_[1].omega_B_rad_s[0], 0.1);
  EXPECT_EQ(out_[1].f_B_m_s2[2], -9.6) << "held, like the estimator node's last accelerometer sample";
  EXPECT_DOUBLE_EQ(out_[1].gyro_dt_s, 0.004);
  EXPECT_DOUBLE_EQ(out_[1].accel_dt_s, 0.004) << "a reused sample has no interval of its own: nominal";
}

TEST_F(ImuCombinerTest, ImuCombiner_GapAfterRollback_DtIsOneNominalPeriod) {
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{1}, 0)));
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{1}, -9.8)));
  ASSERT_TRUE(combiner_.on_gyro(gyro_at(milliseconds{301}, 0)));  // 300 ms later: an old image resumed
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{301}, -9.8)));
  ASSERT_EQ(out_.size(), 2U);
  EXPECT_DOUBLE_EQ(out_[1].gyro_dt_s, 0.004);
  EXPECT_DOUBLE_EQ(out_[1].accel_dt_s, 0.004);
}

TEST_F(ImuCombinerTest, ImuCombiner_NonFiniteGyro_RefusedAndNothingPublished) {
  rejuv_msg_SensorGyro bad = gyro_at(milliseconds{1}, std::numeric_limits<double>::quiet_NaN());
  const auto r = combiner_.on_gyro(bad);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, flight_io::InputError::NotFinite);
  ASSERT_TRUE(combiner_.on_accel(accel_at(milliseconds{1}, -9.8)));
  EXPECT_TRUE(out_.empty());
}

}  // namespace
}  // namespace rejuv::services
