// Sensor models and wind (docs/design.md §9; jMAVSim SimpleSensors, §VI-A).
#include "rejuv/plant/sensors.hpp"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rejuv/plant/wind.hpp"

namespace rejuv::plant {
namespace {

using namespace std::chrono_literals;

constexpr Nanos kPhysicsStep = 1ms;

QuadState hovering() {
  return Quadrotor::hover_at(QuadParams::jmavsim_default(), Eigen::Vector3d(0, 0, -3));
}

// Every sample delivered while the suite runs on a static truth for `duration` at 1 kHz.
struct Recorded {
  std::vector<GyroSample> gyro;
  std::vector<AccelSample> accel;
  std::vector<MagSample> mag;
  std::vector<BaroSample> baro;
  std::vector<GpsSample> gps;
  std::vector<Nanos> gps_delivered_at;
};

Recorded record(SensorSuite& suite, const QuadState& truth, Nanos duration) {
  Recorded r;
  for (Nanos t{0}; t < duration; t += kPhysicsStep) {
    const SensorSamples s = suite.step(t, truth, Eigen::Vector3d::Zero());
    if (s.gyro) r.gyro.push_back(*s.gyro);
    if (s.accel) r.accel.push_back(*s.accel);
    if (s.mag) r.mag.push_back(*s.mag);
    if (s.baro) r.baro.push_back(*s.baro);
    if (s.gps) {
      r.gps.push_back(*s.gps);
      r.gps_delivered_at.push_back(t);
    }
  }
  return r;
}

// Sample standard deviation of one component.
template <class Samples, class Get>
double std_of(const Samples& samples, Get get) {
  double sum = 0;
  double sum2 = 0;
  for (const auto& s : samples) {
    sum += get(s);
    sum2 += get(s) * get(s);
  }
  const double n = static_cast<double>(samples.size());
  const double mean = sum / n;
  return std::sqrt((sum2 - n * mean * mean) / (n - 1));
}

SensorParams without_bias() {
  SensorParams p = SensorParams::defaults();
  p.gyro_bias_rw_rad_s_sqrt_s = 0;
  p.gyro_bias_initial_std_rad_s = 0;
  p.accel_bias_rw_m_s2_sqrt_s = 0;
  p.accel_bias_initial_std_m_s2 = 0;
  p.baro_bias_rw_m_sqrt_s = 0;
  return p;
}

TEST(SensorParams, Defaults_AreValid) {
  EXPECT_TRUE(SensorParams::defaults().validate().has_value());
}

TEST(SensorParams, DelayLongerThanQueue_FailsValidation) {
  SensorParams p = SensorParams::defaults();
  p.gps_delay = 10s;  // 100 GPS periods in flight
  const auto result = p.validate();
  ASSERT_FALSE(result.has_value());
  EXPECT_NE(result.error().find("gps_delay"), std::string::npos);
}

TEST(SensorParams, NegativeNoise_FailsValidation) {
  SensorParams p = SensorParams::defaults();
  p.baro_noise_m = -0.1;
  const auto result = p.validate();
  ASSERT_FALSE(result.has_value());
  EXPECT_NE(result.error().find("baro_noise_m"), std::string::npos);
}

TEST(SensorParams, ZeroPeriod_FailsValidation) {
  SensorParams p = SensorParams::defaults();
  p.mag_period = Nanos{0};
  EXPECT_FALSE(p.validate().has_value());
}

TEST(SensorSuite, Defaults_DeliverAtConfiguredRates) {
  SensorSuite suite(SensorParams::defaults(), 1);
  const Recorded r = record(suite, hovering(), 10s);
  // 10 s: gyro/accel 250 Hz, mag/baro 50 Hz without delay; GPS 10 Hz measured at 0, 0.1, …, 9.9 s and
  // delivered 0.2 s later, so the last two are still in flight.
  EXPECT_EQ(r.gyro.size(), 2500U);
  EXPECT_EQ(r.accel.size(), 2500U);
  EXPECT_EQ(r.mag.size(), 500U);
  EXPECT_EQ(r.baro.size(), 500U);
  EXPECT_EQ(r.gps.size(), 98U);
  for (std::size_t i = 1; i < r.gyro.size(); ++i) {
    ASSERT_EQ(r.gyro[i].t - r.gyro[i - 1].t, 4ms);
  }
  for (std::size_t i = 1; i < r.gps.size(); ++i) {
    ASSERT_EQ(r.gps[i].t - r.gps[i - 1].t, 100ms);
  }
}

TEST(SensorSuite, GpsDelay_DeliversSampleDelayAfterMeasurement) {
  SensorSuite suite(SensorParams::defaults(), 1);
  const Recorded r = record(suite, hovering(), 2s);
  ASSERT_FALSE(r.gps.empty());
  for (std::size_t i = 0; i < r.gps.size(); ++i) {
    EXPECT_EQ(r.gps_delivered_at[i] - r.gps[i].t, 200ms);
  }
}

TEST(SensorSuite, SameSeed_SameSamples) {
  SensorSuite a(SensorParams::defaults(), 42);
  SensorSuite b(SensorParams::defaults(), 42);
  const Recorded ra = record(a, hovering(), 1s);
  const Recorded rb = record(b, hovering(), 1s);
  ASSERT_EQ(ra.gyro.size(), rb.gyro.size());
  for (std::size_t i = 0; i < ra.gyro.size(); ++i) {
    ASSERT_EQ(ra.gyro[i].omega_B_rad_s, rb.gyro[i].omega_B_rad_s);
    ASSERT_EQ(ra.accel[i].f_B_m_s2, rb.accel[i].f_B_m_s2);
  }
  ASSERT_EQ(ra.gps.size(), rb.gps.size());
  for (std::size_t i = 0; i < ra.gps.size(); ++i) {
    ASSERT_EQ(ra.gps[i].p_N_m, rb.gps[i].p_N_m);
  }
}

TEST(SensorSuite, CopiedSuite_ContinuesIdentically) {
  SensorSuite a(SensorParams::defaults(), 7);
  (void)record(a, hovering(), 500ms);
  SensorSuite b = a;  // a checkpoint by copy
  const SensorSamples sa = a.step(500ms, hovering(), Eigen::Vector3d::Zero());
  const SensorSamples sb = b.step(500ms, hovering(), Eigen::Vector3d::Zero());
  ASSERT_TRUE(sa.gyro.has_value() && sb.gyro.has_value());
  EXPECT_EQ(sa.gyro->omega_B_rad_s, sb.gyro->omega_B_rad_s);
}

TEST(SensorSuite, DifferentSeeds_Differ) {
  SensorSuite a(SensorParams::defaults(), 1);
  SensorSuite b(SensorParams::defaults(), 2);
  const Recorded ra = record(a, hovering(), 100ms);
  const Recorded rb = record(b, hovering(), 100ms);
  ASSERT_FALSE(ra.gyro.empty());
  EXPECT_NE(ra.gyro.front().omega_B_rad_s, rb.gyro.front().omega_B_rad_s);
  EXPECT_NE(ra.accel.back().f_B_m_s2, rb.accel.back().f_B_m_s2);
}

TEST(SensorSuite, GyroAndAccelNoise_StdMatchesConfigured) {
  const SensorParams p = without_bias();
  SensorSuite suite(p, 3);
  const Recorded r =
      record(suite, hovering(), 40s);  // 10 000 samples: the std estimate is within ~1.4 % (1σ)
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(std_of(r.gyro, [&](const GyroSample& s) { return s.omega_B_rad_s(axis); }),
                p.gyro_noise_rad_s, 0.05 * p.gyro_noise_rad_s);
    EXPECT_NEAR(std_of(r.accel, [&](const AccelSample& s) { return s.f_B_m_s2(axis); }), p.accel_noise_m_s2,
                0.05 * p.accel_noise_m_s2);
  }
}

TEST(SensorSuite, GpsAndBaroNoise_StdMatchesConfigured) {
  const SensorParams p = without_bias();
  SensorSuite suite(p, 4);
  const Recorded r = record(suite, hovering(), 400s);  // 4 000 GPS, 20 000 baro samples
  EXPECT_NEAR(std_of(r.gps, [](const GpsSample& s) { return s.p_N_m.x(); }), p.gps_horizontal_noise_m,
              0.06 * p.gps_horizontal_noise_m);
  EXPECT_NEAR(std_of(r.gps, [](const GpsSample& s) { return s.p_N_m.z(); }), p.gps_vertical_noise_m,
              0.06 * p.gps_vertical_noise_m);
  EXPECT_NEAR(std_of(r.gps, [](const GpsSample& s) { return s.v_N_m_s.y(); }), p.gps_velocity_noise_m_s,
              0.06 * p.gps_velocity_noise_m_s);
  EXPECT_NEAR(std_of(r.baro, [](const BaroSample& s) { return s.altitude_m; }), p.baro_noise_m,
              0.05 * p.baro_noise_m);
}

TEST(SensorSuite, Hovering_AccelMeasuresMinusGravityInBody) {
  SensorSuite suite(without_bias(), 5);
  const Recorded r = record(suite, hovering(), 4s);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const AccelSample& s : r.accel) {
    mean += s.f_B_m_s2;
  }
  mean /= static_cast<double>(r.accel.size());
  EXPECT_TRUE(mean.isApprox(Eigen::Vector3d(0, 0, -9.81), 1e-3));
}

TEST(SensorSuite, YawedVehicle_MagMeasuresFieldInBody) {
  SensorParams p = SensorParams::defaults();
  p.mag_noise_gauss = 0;
  SensorSuite suite(p, 6);
  QuadState truth = hovering();
  truth.q_NB = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ());  // nose east
  const SensorSamples s = suite.step(Nanos{0}, truth, Eigen::Vector3d::Zero());
  ASSERT_TRUE(s.mag.has_value());
  // Field mostly north: seen from a nose-east body it points to the body's left (−y_B).
  const Eigen::Vector3d& b_N = p.mag_field_N_gauss;
  EXPECT_TRUE(s.mag->b_B_gauss.isApprox(Eigen::Vector3d(b_N.y(), -b_N.x(), b_N.z()), 1e-12));
}

TEST(SensorSuite, Baro_PressureFollowsStandardAtmosphere) {
  SensorParams p = SensorParams::defaults();
  p.baro_noise_m = 0;
  p.baro_bias_rw_m_sqrt_s = 0;
  SensorSuite suite(p, 8);
  QuadState high = hovering();
  high.p_NB_N.z() = -100;
  const SensorSamples low_sample = suite.step(Nanos{0}, hovering(), Eigen::Vector3d::Zero());
  SensorSuite suite2(p, 8);
  const SensorSamples high_sample = suite2.step(Nanos{0}, high, Eigen::Vector3d::Zero());
  ASSERT_TRUE(low_sample.baro && high_sample.baro);
  EXPECT_NEAR(low_sample.baro->altitude_m, 3.0, 1e-12);
  // At 490–590 m the pressure falls ≈ 11.3 Pa per metre (ρ g with ρ ≈ 1.15 kg/m³).
  const double dp_per_m = (low_sample.baro->pressure_pa - high_sample.baro->pressure_pa) / 97.0;
  EXPECT_NEAR(dp_per_m, 11.3, 0.5);
}

TEST(SensorSuite, BiasRandomWalk_GrowsLikeSqrtTime) {
  // Bias random walk only; over many seeds the spread after T is rw √T.
  SensorParams p = without_bias();
  p.gyro_bias_rw_rad_s_sqrt_s = 0.01;
  double sum2 = 0;
  constexpr int kSeeds = 400;
  for (int seed = 0; seed < kSeeds; ++seed) {
    SensorSuite suite(p, static_cast<std::uint64_t>(seed));
    (void)record(suite, hovering(), 4s);
    sum2 += suite.gyro_bias_B_rad_s().x() * suite.gyro_bias_B_rad_s().x();
  }
  EXPECT_NEAR(std::sqrt(sum2 / kSeeds), 0.01 * std::sqrt(4.0), 0.1 * 0.02);
}

TEST(Wind, Gusts_StdAndMeanMatchConfigured) {
  const WindParams params{
      .mean_N_m_s = Eigen::Vector3d(2, -1, 0), .gust_std_m_s = 1.5, .gust_time_constant_s = 0.5};
  Wind wind(params, 11);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum2 = Eigen::Vector3d::Zero();
  constexpr int kSteps = 500'000;  // 2000 s at 250 Hz: 4000 correlation times
  for (int i = 0; i < kSteps; ++i) {
    const Eigen::Vector3d w = wind.step(Seconds{4e-3});
    sum += w;
    sum2 += w.cwiseAbs2();
  }
  const Eigen::Vector3d mean = sum / kSteps;
  const Eigen::Vector3d std_dev = (sum2 / kSteps - mean.cwiseAbs2()).cwiseSqrt();
  EXPECT_LT((mean - params.mean_N_m_s).norm(), 0.15);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(std_dev(axis), params.gust_std_m_s, 0.08 * params.gust_std_m_s);
  }
}

TEST(Wind, SameSeed_SameWindDifferentSeed_Differs) {
  const WindParams params{
      .mean_N_m_s = Eigen::Vector3d::Zero(), .gust_std_m_s = 1.0, .gust_time_constant_s = 2.0};
  Wind a(params, 5);
  Wind b(params, 5);
  Wind c(params, 6);
  Eigen::Vector3d wa;
  Eigen::Vector3d wc;
  for (int i = 0; i < 100; ++i) {
    wa = a.step(Seconds{1e-3});
    wc = c.step(Seconds{1e-3});
    ASSERT_EQ(wa, b.step(Seconds{1e-3}));
  }
  EXPECT_NE(wa, wc);
}

TEST(Wind, NoGusts_IsTheMean) {
  const WindParams params{.mean_N_m_s = Eigen::Vector3d(1, 2, 0)};
  Wind wind(params, 1);
  EXPECT_EQ(wind.step(Seconds{0.01}), params.mean_N_m_s);
}

}  // namespace
}  // namespace rejuv::plant
