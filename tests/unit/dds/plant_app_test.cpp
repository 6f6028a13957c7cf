// The plant process's parts that need no DDS: strict option parsing and the I/O-free simulation.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "rejuv/dds/plant_topics.hpp"
#include "rejuv/plant_app/options.hpp"
#include "rejuv/plant_app/plant_sim.hpp"

namespace rejuv::plant_app {
namespace {

using namespace std::chrono_literals;

Result<PlantCommand, std::string> parse(std::vector<std::string_view> args) {
  return parse_options(args);
}

PlantOptions parse_ok(std::vector<std::string_view> args) {
  auto c = parse(std::move(args));
  EXPECT_TRUE(c.has_value()) << (c ? "" : c.error());
  if (!c || !std::holds_alternative<PlantOptions>(*c)) return {};
  return std::get<PlantOptions>(*c);
}

std::string parse_error(std::vector<std::string_view> args) {
  auto c = parse(std::move(args));
  EXPECT_FALSE(c.has_value());
  return c ? std::string{} : c.error();
}

TEST(PlantOptions, NoArguments_Defaults) {
  const PlantOptions o = parse_ok({});
  EXPECT_EQ(o.domain, 0U);
  EXPECT_EQ(o.clock, ClockMode::Lockstep);
  EXPECT_EQ(o.step, 4ms);
  EXPECT_TRUE(o.start_N_m.isApprox(Eigen::Vector3d(0, 0, -3)));
  EXPECT_EQ(o.duration, 0s);
  EXPECT_EQ(o.alignment, 20s);  // as rejuv sim (flight::SimConfig::alignment)
}

TEST(PlantOptions, EveryFlag_Parsed) {
  const PlantOptions o = parse_ok({"--domain",
                                   "17",
                                   "--seed=18446744073709551615",
                                   "--clock",
                                   "realtime",
                                   "--start-north",
                                   "1.5",
                                   "--start-east",
                                   "-2",
                                   "--start-down",
                                   "-10",
                                   "--duration",
                                   "2.5",
                                   "--step-ms",
                                   "8",
                                   "--ack-timeout-ms",
                                   "250",
                                   "--connect-timeout-ms",
                                   "1000",
                                   "--wind-mean",
                                   "3",
                                   "--wind-gust",
                                   "0.5",
                                   "--align-s",
                                   "1.5",
                                   "--wind-toward",
                                   "270"});
  EXPECT_EQ(o.domain, 17U);
  EXPECT_EQ(o.seed, 18446744073709551615ULL);
  EXPECT_EQ(o.clock, ClockMode::Realtime);
  EXPECT_TRUE(o.start_N_m.isApprox(Eigen::Vector3d(1.5, -2, -10)));
  EXPECT_EQ(o.duration, 2500ms);
  EXPECT_EQ(o.step, 8ms);
  EXPECT_EQ(o.ack_timeout, 250ms);
  EXPECT_EQ(o.connect_timeout, 1000ms);
  EXPECT_DOUBLE_EQ(o.wind_mean_m_s, 3);
  EXPECT_DOUBLE_EQ(o.wind_gust_m_s, 0.5);
  EXPECT_DOUBLE_EQ(o.wind_toward_deg, 270);
  EXPECT_EQ(o.alignment, 1500ms);
}

TEST(PlantOptions, WindTowardOutsideAFullTurn_Refused) {
  EXPECT_NE(parse_error({"--wind-toward", "360"}).find("--wind-toward: expected degrees in [0, 360)"),
            std::string::npos);
  EXPECT_NE(parse_error({"--wind-toward", "-1"}).find("--wind-toward"), std::string::npos);
  EXPECT_NE(parse_error({"--wind-toward", "nan"}).find("--wind-toward"), std::string::npos);
}

TEST(PlantOptions, Help_ShowHelp) {
  auto c = parse({"--domain", "3", "--help"});
  ASSERT_TRUE(c.has_value());
  EXPECT_TRUE(std::holds_alternative<ShowHelp>(*c));
  EXPECT_NE(usage().find("--ack-timeout-ms"), std::string_view::npos);
}

// The help states the lockstep timeouts' defaults as PlantOptions has them (one spelling of each).
TEST(PlantOptions, Help_StatesTheTimeoutDefaultsOfPlantOptions) {
  const PlantOptions defaults{};
  for (const auto& [flag, value] : {std::pair{"--ack-timeout-ms", defaults.ack_timeout},
                                    std::pair{"--connect-timeout-ms", defaults.connect_timeout}}) {
    const std::string_view text = usage();
    const std::size_t at = text.find(flag);
    ASSERT_NE(at, std::string_view::npos) << flag;
    const std::string_view line = text.substr(at, text.find('\n', at) - at);
    const std::string stated =
        "(default " + std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(value).count()) + ")";
    EXPECT_NE(line.find(stated), std::string_view::npos) << line;
  }
}

TEST(PlantOptions, UnknownFlag_Named) {
  EXPECT_NE(parse_error({"--speed", "3"}).find("unknown option '--speed'"), std::string::npos);
}

TEST(PlantOptions, MissingValue_Named) {
  EXPECT_NE(parse_error({"--seed"}).find("--seed: missing value"), std::string::npos);
}

TEST(PlantOptions, TrailingGarbage_Refused) {
  EXPECT_NE(parse_error({"--step-ms", "4ms"}).find("--step-ms: expected an integer"), std::string::npos);
}

TEST(PlantOptions, OutOfRange_Refused) {
  EXPECT_NE(parse_error({"--domain", "233"}).find("--domain"), std::string::npos);
  EXPECT_NE(parse_error({"--step-ms", "0"}).find("--step-ms"), std::string::npos);
  EXPECT_NE(parse_error({"--start-down", "1"}).find("--start-down"), std::string::npos);  // below ground
  EXPECT_NE(parse_error({"--duration", "-1"}).find("--duration"), std::string::npos);
}

TEST(PlantOptions, NonFiniteNumber_Refused) {
  EXPECT_NE(parse_error({"--wind-mean", "nan"}).find("--wind-mean"), std::string::npos);
  EXPECT_NE(parse_error({"--start-north", "inf"}).find("--start-north"), std::string::npos);
}

TEST(PlantOptions, NegativeSeed_Refused) {
  EXPECT_NE(parse_error({"--seed", "-1"}).find("--seed"), std::string::npos);
}

TEST(PlantOptions, BadClock_Named) {
  EXPECT_NE(parse_error({"--clock", "fast"}).find("expected lockstep or realtime"), std::string::npos);
}

TEST(PlantOptions, DuplicateFlag_Refused) {
  EXPECT_NE(parse_error({"--seed", "1", "--seed=2"}).find("given twice"), std::string::npos);
}

TEST(PlantOptions, RunId_SixteenHexDigitsParsedOtherwiseRefused) {
  EXPECT_FALSE(parse_ok({}).run_id.has_value());  // the default partition
  const PlantOptions o = parse_ok({"--run-id", "00C0ffee12345678"});
  ASSERT_TRUE(o.run_id.has_value());
  EXPECT_EQ(o.run_id->value(), 0x00c0ffee12345678ULL);
  for (const char* bad : {"c0ffee", "00c0ffee123456789", "00c0ffee1234567g", "+0c0ffee12345678", ""}) {
    EXPECT_NE(parse_error({"--run-id", bad}).find("--run-id: expected 16 hex digits"), std::string::npos) << bad;
  }
}

TEST(PlantOptions, DdsNames_RejuvByDefaultRos2OnRequestOtherwiseRefused) {
  EXPECT_EQ(parse_ok({}).naming, DdsNaming::Rejuv);
  EXPECT_EQ(parse_ok({"--dds-names", "ros2"}).naming, DdsNaming::Ros2);
  EXPECT_EQ(parse_ok({"--dds-names", "rejuv"}).naming, DdsNaming::Rejuv);
  EXPECT_NE(parse_error({"--dds-names", "ROS2"}).find("--dds-names: expected rejuv or ros2, got 'ROS2'"), std::string::npos);
}

TEST(PlantOptions, Positional_Refused) {
  EXPECT_NE(parse_error({"lockstep"}).find("unexpected argument"), std::string::npos);
}

// ---- PlantSim ----

struct Collected {
  std::vector<rejuv_msg_SensorGyro> gyro;
  std::vector<rejuv_msg_SensorAccel> accel;
  std::vector<rejuv_msg_SensorMag> mag;
  std::vector<rejuv_msg_SensorBaro> baro;
  std::vector<rejuv_msg_SensorGps> gps;
};

Collected run_sim(std::uint64_t seed, Nanos total, Nanos step) {
  PlantSim sim(PlantSimConfig{.seed = seed});
  Collected c;
  std::vector<SensorMessage> out;
  for (Nanos t{0}; t < total; t += step) {
    out.clear();
    sim.advance(step, out);
    for (const SensorMessage& m : out) {
      std::visit(
          [&](const auto& s) {
            using T = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<T, rejuv_msg_SensorGyro>) c.gyro.push_back(s);
            if constexpr (std::is_same_v<T, rejuv_msg_SensorAccel>) c.accel.push_back(s);
            if constexpr (std::is_same_v<T, rejuv_msg_SensorMag>) c.mag.push_back(s);
            if constexpr (std::is_same_v<T, rejuv_msg_SensorBaro>) c.baro.push_back(s);
            if constexpr (std::is_same_v<T, rejuv_msg_SensorGps>) c.gps.push_back(s);
          },
          m);
    }
  }
  return c;
}

TEST(PlantSim, Advance_OneSecond_SensorsAtTheirRates) {
  const Collected c = run_sim(1, 1s, 4ms);
  // 250 Hz, 250 Hz, 50 Hz, 50 Hz, 10 Hz (GPS delayed 200 ms: 8 of its 10 samples are delivered by t = 1 s).
  EXPECT_NEAR(static_cast<double>(c.gyro.size()), 250, 1);
  EXPECT_NEAR(static_cast<double>(c.accel.size()), 250, 1);
  EXPECT_NEAR(static_cast<double>(c.mag.size()), 50, 1);
  EXPECT_NEAR(static_cast<double>(c.baro.size()), 50, 1);
  EXPECT_NEAR(static_cast<double>(c.gps.size()), 8, 1);
}

TEST(PlantSim, Advance_SameSeed_SameSamples) {
  const Collected a = run_sim(7, 200ms, 4ms);
  const Collected b = run_sim(7, 200ms, 4ms);
  ASSERT_EQ(a.gyro.size(), b.gyro.size());
  ASSERT_FALSE(a.gyro.empty());
  for (std::size_t i = 0; i < a.gyro.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.gyro[i], &b.gyro[i], sizeof a.gyro[i]), 0) << i;
  }
  ASSERT_EQ(a.accel.size(), b.accel.size());
  for (std::size_t i = 0; i < a.accel.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.accel[i], &b.accel[i], sizeof a.accel[i]), 0) << i;
  }
}

TEST(PlantSim, Advance_OtherSeed_OtherNoise) {
  const Collected a = run_sim(7, 40ms, 4ms);
  const Collected b = run_sim(8, 40ms, 4ms);
  ASSERT_FALSE(a.gyro.empty());
  EXPECT_NE(a.gyro[0].omega_B_rad_s[0], b.gyro[0].omega_B_rad_s[0]);
}

TEST(PlantSim, Hover_HeldCommand_StaysNearStart) {
  PlantSim sim(PlantSimConfig{.seed = 1, .start_N_m = Eigen::Vector3d(1, 2, -3)});
  std::vector<SensorMessage> out;
  sim.advance(2s, out);
  const rejuv_msg_GroundTruth gt = sim.ground_truth();
  EXPECT_EQ(gt.timestamp_ns, 2'000'000'000U);
  EXPECT_NEAR(gt.p_N_m[0], 1, 1e-6);
  EXPECT_NEAR(gt.p_N_m[1], 2, 1e-6);
  EXPECT_NEAR(gt.p_N_m[2], -3, 1e-6);
}

TEST(PlantSim, Advance_IntervalNotMultipleOfTick_ExactTime) {
  PlantSim sim(PlantSimConfig{});
  std::vector<SensorMessage> out;
  sim.advance(Nanos{2'500'000}, out);  // 2.5 ticks: the last is a half tick
  EXPECT_EQ(sim.now(), Nanos{2'500'000});
}

TEST(PlantSim, MotorCommand_NonFinite_RefusedAndPreviousHeld) {
  PlantSim sim(PlantSimConfig{});
  rejuv_msg_ActuatorOutputs u{};
  for (double& m : u.motor) m = 0.7;
  ASSERT_TRUE(sim.set_motor_command(u));
  u.motor[2] = std::nan("");
  EXPECT_FALSE(sim.set_motor_command(u));
  EXPECT_TRUE(sim.motor_command().isApprox(Eigen::Vector4d::Constant(0.7)));
}

TEST(PlantSim, Aligning_FullThrottle_HeldAtStartWhileSensorsSample) {
  PlantSim sim(PlantSimConfig{.seed = 1, .start_N_m = Eigen::Vector3d(1, 2, -3), .alignment = 1s});
  rejuv_msg_ActuatorOutputs u{};
  for (double& m : u.motor) m = 1.0;
  ASSERT_TRUE(sim.set_motor_command(u));
  std::vector<SensorMessage> out;
  sim.advance(1s, out);
  const rejuv_msg_GroundTruth gt = sim.ground_truth();
  EXPECT_EQ(gt.p_N_m[0], 1.0);  // exactly: no physics while aligning
  EXPECT_EQ(gt.p_N_m[1], 2.0);
  EXPECT_EQ(gt.p_N_m[2], -3.0);
  EXPECT_EQ(gt.v_N_m_s[2], 0.0);
  EXPECT_GT(out.size(), 500U);  // gyro and accel at 250 Hz, mag, baro, GPS
  EXPECT_FALSE(sim.aligning());
}

TEST(PlantSim, AfterAlignment_HeldCommand_Applied) {
  PlantSim sim(PlantSimConfig{.seed = 1, .start_N_m = Eigen::Vector3d(0, 0, -3), .alignment = 100ms});
  rejuv_msg_ActuatorOutputs u{};
  for (double& m : u.motor) m = 1.0;
  ASSERT_TRUE(sim.set_motor_command(u));  // received while aligning: applied once the flight starts
  std::vector<SensorMessage> out;
  sim.advance(600ms, out);
  EXPECT_LT(sim.ground_truth().p_N_m[2], -3.1);  // NED: up is negative z
}

TEST(PlantSim, FullThrottle_Climbs) {
  PlantSim sim(PlantSimConfig{});
  rejuv_msg_ActuatorOutputs u{};
  for (double& m : u.motor) m = 1.0;
  ASSERT_TRUE(sim.set_motor_command(u));
  std::vector<SensorMessage> out;
  sim.advance(500ms, out);
  EXPECT_LT(sim.ground_truth().p_N_m[2], -3.1);  // NED: up is negative z
}

// A usual 4 ms step fits its SimStep whole: nothing goes out on its own topic.
TEST(PackStep, UsualStep_EverySampleInTheStep) {
  PlantSim sim(PlantSimConfig{.seed = 1});
  std::vector<SensorMessage> batch;
  std::vector<SensorMessage> overflow;
  std::size_t packed = 0;
  for (int k = 0; k < 250; ++k) {  // one second: every sensor has delivered at least once
    batch.clear();
    sim.advance(4ms, batch);
    rejuv_msg_SimStep step{};
    step.gyro_count = 9;  // the counts start from zero whatever the struct held
    pack_step(batch, sim.ground_truth(), step, overflow);
    packed += dds::plant_topics::samples_in(step) - 1;  // every sensor's, by the step table (less the truth)
    ASSERT_EQ(step.gyro_count, 1);
    ASSERT_EQ(step.accel_count, 1);
    EXPECT_EQ(std::memcmp(&step.gyro[0], &std::get<rejuv_msg_SensorGyro>(batch[0]), sizeof step.gyro[0]), 0);
    EXPECT_EQ(step.ground_truth.timestamp_ns, static_cast<std::uint64_t>(sim.now().count()));
  }
  EXPECT_TRUE(overflow.empty());
  EXPECT_GT(packed, 500U + 2 * 49U);  // gyro, accel, mag, baro and GPS all travelled in steps
}

// A step that follows a charged checkpoint covers several sensor periods: the oldest samples of a kind
// fill its array, the rest keep their order on the side.
TEST(PackStep, LongStep_OldestInTheStepRestInOrderOnTheSide) {
  PlantSim sim(PlantSimConfig{.seed = 1});
  std::vector<SensorMessage> batch;
  sim.advance(24ms, batch);  // six gyro and six accel samples, one or two of mag and baro
  rejuv_msg_SimStep step{};
  std::vector<SensorMessage> overflow;
  pack_step(batch, sim.ground_truth(), step, overflow);
  ASSERT_EQ(step.gyro_count, 2);
  ASSERT_EQ(step.accel_count, 2);
  std::vector<std::uint64_t> side_gyro;
  for (const SensorMessage& m : overflow) {
    if (const auto* g = std::get_if<rejuv_msg_SensorGyro>(&m)) side_gyro.push_back(g->timestamp_ns);
  }
  ASSERT_EQ(side_gyro.size(), 4U);
  EXPECT_LT(step.gyro[0].timestamp_ns, step.gyro[1].timestamp_ns);
  EXPECT_LT(step.gyro[1].timestamp_ns, side_gyro.front());
  EXPECT_TRUE(std::is_sorted(side_gyro.begin(), side_gyro.end()));
  const std::size_t total = dds::plant_topics::samples_in(step) - 1 + overflow.size();  // less the ground truth
  EXPECT_EQ(total, batch.size());  // nothing lost, nothing twice
}

}  // namespace
}  // namespace rejuv::plant_app
