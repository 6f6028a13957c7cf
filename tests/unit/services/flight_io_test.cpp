// flight_io: the services read the launch graph's params into exactly the simulation's configuration, and
// a state, setpoint or control that crosses a topic comes back bit-identical.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>

#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/flight_io/messages.hpp"
#include "rejuv/flight_io/params.hpp"

namespace rejuv::flight_io {
namespace {

using Table = std::map<std::string, graph_values::Value, std::less<>>;  // as flight_io::Params::from_table

TEST(FlightIoParams, ControlDesign_NoParams_IsTheSimulationsDesign) {
  auto sim = flight::SrSimulation::create(flight::SimConfig::defaults());
  ASSERT_TRUE(sim) << sim.error().to_string();
  auto ours = control_design(Params::from_table({}));
  ASSERT_TRUE(ours) << ours.error().to_string();
  const flight::ControlDesign& theirs = sim->design();
  EXPECT_EQ(ours->ellipsoid.P(), theirs.ellipsoid.P());
  EXPECT_EQ(ours->mission.K(), theirs.mission.K());
  EXPECT_EQ(ours->safety.K(), theirs.safety.K());
  EXPECT_EQ(ours->restricted.lo, theirs.restricted.lo);
  EXPECT_EQ(ours->restricted.hi, theirs.restricted.hi);
  EXPECT_EQ(ours->full.hi, theirs.full.hi);
  EXPECT_EQ(ours->u_hover, theirs.u_hover);
  EXPECT_EQ(ours->discrete.period.count(), 0.004);
}

TEST(FlightIoParams, ActuatorLimits_NoParams_AreTheDesignsLimits) {
  auto design = control_design(Params::from_table({}));
  auto limits = actuator_limits(Params::from_table({}));
  ASSERT_TRUE(design && limits);
  EXPECT_EQ(limits->full.lo, design->full.lo);
  EXPECT_EQ(limits->full.hi, design->full.hi);
  EXPECT_EQ(limits->restricted.lo, design->restricted.lo);
  EXPECT_EQ(limits->restricted.hi, design->restricted.hi);
  EXPECT_EQ(limits->u_hover, design->u_hover);
}

TEST(FlightIoParams, ControlDesign_LaunchGraphValues_ChangeTheDesign) {
  const flight::ControlDesignSpec defaults = flight::SimConfig::defaults().control;
  auto narrow = control_design(
      Params::from_table({{"sr.box.position_m", defaults.box.position_m / 2},
                          {"sr.restricted_limit_fraction", defaults.restricted_limit_fraction / 2}}));
  auto wide = control_design(Params::from_table({}));
  ASSERT_TRUE(narrow && wide);
  EXPECT_GT(narrow->ellipsoid.scale(), wide->ellipsoid.scale()) << "a smaller box scales P up";
  EXPECT_LT(narrow->restricted.hi[0], wide->restricted.hi[0]);
}

TEST(FlightIoParams, TrackingParams_NoParams_AreTheSimulations) {
  const flight::SimConfig sim = flight::SimConfig::defaults();
  auto t = tracking_params(Params::from_table({}));
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sr, sim.sr);
  EXPECT_EQ(t->rho_M, sim.rho_M);
  EXPECT_EQ(t->rho_s, sim.handler.rho_s);
  EXPECT_EQ(t->t_min, sim.handler.t_min);
  EXPECT_EQ(t->check_period, sim.handler.check_period);
}

TEST(FlightIoParams, EkfRearm_NoParams_AreTheSimulations) {
  const flight::EkfRearm sim = flight::SimConfig::defaults().ekf_rearm;
  auto r = ekf_rearm(Params::from_table({}));
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->enabled);
  EXPECT_EQ(r->position_std_m, sim.position_std_m);
  EXPECT_EQ(r->accel_bias_std_m_s2, sim.accel_bias_std_m_s2);
}

// The launch file's sr.ekf_rearm, as the kernel passes it: what is set replaces the default, the rest stays.
TEST(FlightIoParams, EkfRearm_LaunchValues_ReplaceTheDefaults) {
  auto r = ekf_rearm(Params::from_table({{"sr.ekf_rearm.enabled", 0}, {"sr.ekf_rearm.attitude_std_rad", 0.2}}));
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->enabled);
  EXPECT_EQ(r->attitude_std_rad, 0.2);
  EXPECT_EQ(r->position_std_m, flight::SimConfig::defaults().ekf_rearm.position_std_m);
}

TEST(FlightIoParams, EkfRearm_BadValues_RefusedNamingTheParam) {
  auto zero = ekf_rearm(Params::from_table({{"sr.ekf_rearm.velocity_std_m_s", 0}}));
  ASSERT_FALSE(zero);
  EXPECT_EQ(zero.error().where, "sr.ekf_rearm.velocity_std_m_s");
  auto nan = ekf_rearm(Params::from_table({{"sr.ekf_rearm.gyro_bias_std_rad_s", std::numeric_limits<double>::quiet_NaN()}}));
  ASSERT_FALSE(nan);
  EXPECT_EQ(nan.error().where, "sr.ekf_rearm.gyro_bias_std_rad_s");
  auto on = ekf_rearm(Params::from_table({{"sr.ekf_rearm.enabled", 0.5}}));
  ASSERT_FALSE(on);
  EXPECT_EQ(on.error().where, "sr.ekf_rearm.enabled");
}

TEST(FlightIoParams, TrackingParams_SrDisabled_IsOff) {
  auto t = tracking_params(Params::from_table({{"sr.enabled", 0}}));
  ASSERT_TRUE(t);
  EXPECT_EQ(t->sr, flight::SrSwitch::Off);
}

TEST(FlightIoParams, TrackingParams_RhoSNotBelowRhoM_Refused) {
  auto t = tracking_params(Params::from_table({{"sr.rho_s", 0.2}, {"sr.rho_m", 0.1}}));
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().kind, InputError::OutOfRange);
  EXPECT_EQ(t.error().where, "sr.rho_s");
}

TEST(FlightIoParams, TrackingParams_EnabledNotZeroOrOne_Refused) {
  auto t = tracking_params(Params::from_table({{"sr.enabled", 2}}));
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().where, "sr.enabled");
}

TEST(FlightIoParams, TrackingParams_NanCheckPeriod_Refused) {
  auto t =
      tracking_params(Params::from_table({{"sr.check_period_s", std::numeric_limits<double>::quiet_NaN()}}));
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().kind, InputError::NotFinite);
  EXPECT_EQ(t.error().where, "sr.check_period_s");
}

TEST(FlightIoParams, ControlSpec_NonPositiveBox_Refused) {
  auto s = control_spec(Params::from_table({{"sr.box.angle_rad", 0.0}}));
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().kind, InputError::OutOfRange);
  EXPECT_EQ(s.error().where, "sr.box.angle_rad");
}

TEST(FlightIoParams, ControlDesign_UnreachableRestrictedLimits_RefusedByTheDesign) {
  // Ū = U: its corners need rotor levels outside [0, 1] (flight::restricted_limits).
  auto d = control_design(Params::from_table({{"sr.restricted_limit_fraction", 1.0}}));
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().kind, InputError::Design);
  EXPECT_EQ(d.error().where, "sr.restricted_limit_fraction");
}

TEST(FlightIoParams, EkfParams_AreTheSimulations) {
  const flight::SimConfig sim = flight::SimConfig::defaults();
  const flight::EkfParams p = ekf_params();
  EXPECT_EQ(p.gps_delay, to_seconds(sim.sensors.gps_delay));
  EXPECT_EQ(p.gravity_m_s2, sim.quad.gravity_m_s2);
  EXPECT_EQ(imu_period(), sim.sensors.gyro_period);
}

TEST(FlightIoMessages, VehicleState_RoundTrip_GivesTheEstimatorsStateExactly) {
  flight::EstimatorNode node(ekf_params(),
                             flight::EkfState{.p_N_m = {0.1, 0.2, -3},
                                              .v_N_m_s = {0.01, 0, 0},
                                              .q_NB = Eigen::Quaterniond(Eigen::AngleAxisd(
                                                  0.3, Eigen::Vector3d(1, 2, 3).normalized()))},
                             imu_period());
  plant::SensorSamples s;
  s.gyro = plant::GyroSample{.t = std::chrono::milliseconds{1}, .omega_B_rad_s = {0.1, -0.2, 0.05}};
  s.accel = plant::AccelSample{.t = std::chrono::milliseconds{1}, .f_B_m_s2 = {0.3, 0.1, -9.7}};
  ASSERT_TRUE(node.on_samples(s));
  const rejuv_msg_VehicleStateEstimate m =
      vehicle_state_message(node, std::chrono::milliseconds{1}, kStateAttitudeValid);
  const auto x = state_from_message(m);
  ASSERT_TRUE(x);
  EXPECT_EQ(*x, node.estimate());
  EXPECT_GT(m.variance_p_m2[0], 0.0);
}

TEST(FlightIoMessages, VehicleState_ZeroQuaternion_Refused) {
  rejuv_msg_VehicleStateEstimate m{};
  const auto x = state_from_message(m);
  ASSERT_FALSE(x);
  EXPECT_EQ(x.error().kind, InputError::OutOfRange);
}

TEST(FlightIoMessages, Setpoint_RoundTrip_IsExact) {
  const flight::StateVec x_sp = flight::hover_setpoint({0.123456789, 1.0 / 3.0, -3}, -2.5);
  const auto back = setpoint_from_message(setpoint_message(x_sp, Nanos{7}, 2, false));
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, x_sp);
}

TEST(FlightIoMessages, Controls_RoundTrip_IsExact) {
  flight::InputVec u;
  u << 7.9, 0.01, -0.02, 1.0 / 3.0;
  const rejuv_msg_ActuatorControls m = controls_message(u, Nanos{9}, Epoch{4});
  EXPECT_EQ(m.epoch, 4U);
  const auto back = controls_from_message(m);
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, u);
}

TEST(FlightIoMessages, Mode_OutOfRange_Refused) {
  rejuv_msg_SrMode m{};
  m.mode = rejuv_msg_SR_MODE_UPDATE;
  EXPECT_EQ(mode_from_message(m).value(), SrMode::Update);
  m.mode = static_cast<rejuv_msg_SrModeKind>(9);
  const auto r = mode_from_message(m);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, InputError::OutOfRange);
}

TEST(FlightIoMessages, Stamp_NegativeTime_IsZero) {
  EXPECT_EQ(stamp(Nanos{-5}), 0U);
  EXPECT_EQ(time_of(stamp(Nanos{123})), Nanos{123});
}

}  // namespace
}  // namespace rejuv::flight_io
