// output_driver: the limits of the mode, then the inverse mixer: mixer(outputs) ≈ controls within the limits.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>

#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/services/output_driver/driver_node.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;

class DriverNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto l = flight_io::actuator_limits(flight_io::Params::from_table({}));
    ASSERT_TRUE(l) << l.error().to_string();
    limits_ = *l;
  }
  [[nodiscard]] DriverNode make(SrMode mode) const { return DriverNode(mixer_.inverse(), limits_, mode); }
  [[nodiscard]] flight::InputVec wrench(const rejuv_msg_ActuatorOutputs& out) const {
    return mixer_.wrench_from_motors(Eigen::Vector4d(out.motor[0], out.motor[1], out.motor[2], out.motor[3]));
  }
  static rejuv_msg_ActuatorControls controls(const flight::InputVec& u) {
    return flight_io::controls_message(u, milliseconds{4}, Epoch{0});
  }

  plant::Mixer mixer_{flight::SimConfig::defaults().quad};
  flight_io::ActuatorLimits limits_;
};

TEST_F(DriverNodeTest, DriverNode_ControlsWithinRestrictedLimits_MixerOfOutputsGivesThemBack) {
  DriverNode driver = make(SrMode::MC);
  flight::InputVec u = limits_.u_hover;
  u += 0.5 * (limits_.restricted.hi - limits_.u_hover);
  const auto out = driver.on_controls(controls(u), milliseconds{5});
  ASSERT_TRUE(out) << out.error().to_string();
  EXPECT_TRUE(wrench(*out).isApprox(u, 1e-12)) << wrench(*out).transpose() << " vs " << u.transpose();
  EXPECT_EQ(out->limits_restricted, 1);
  EXPECT_EQ(out->timestamp_ns, 5'000'000U);
  for (const double U : out->motor) {
    EXPECT_GE(U, 0.0);
    EXPECT_LE(U, 1.0);
  }
}

TEST_F(DriverNodeTest, DriverNode_InMc_ClampsToTheRestrictedLimits) {
  DriverNode driver = make(SrMode::MC);
  const flight::InputVec u = limits_.full.hi;  // a corner of U, far outside Ū
  const auto out = driver.on_controls(controls(u), milliseconds{4});
  ASSERT_TRUE(out);
  EXPECT_TRUE(wrench(*out).isApprox(limits_.restricted.hi, 1e-12)) << wrench(*out).transpose();
  EXPECT_TRUE(driver.driver().applied_u().isApprox(limits_.restricted.hi, 1e-12));
}

TEST_F(DriverNodeTest, DriverNode_LimitsRecord_ARestrictedOneReplacesUbar_OthersAreRefused) {
  DriverNode driver = make(SrMode::MC);
  flight::InputBox narrow = limits_.restricted;
  narrow.hi = limits_.u_hover + 0.5 * (limits_.restricted.hi - limits_.u_hover);
  // The full set, a truncated record and a non-finite one are refused: Ū stays.
  const auto full = flight_io::limits_bytes(flight_io::limits_record(limits_.full, flight::LimitSet::Full));
  EXPECT_FALSE(driver.on_limits(full).has_value());
  EXPECT_FALSE(driver.on_limits(std::span(full).first(full.size() - 1)).has_value());
  auto nan = flight_io::limits_record(narrow, flight::LimitSet::Restricted);
  nan.hi[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(driver.on_limits(flight_io::limits_bytes(nan)).has_value());
  auto out = driver.on_controls(controls(limits_.full.hi), milliseconds{4});
  ASSERT_TRUE(out);
  EXPECT_TRUE(wrench(*out).isApprox(limits_.restricted.hi, 1e-12));
  // A valid restricted record (what checkpoint_p writes before MC) is the Ū applied from then on.
  ASSERT_TRUE(driver.on_limits(flight_io::limits_bytes(flight_io::limits_record(narrow, flight::LimitSet::Restricted))));
  out = driver.on_controls(controls(limits_.full.hi), milliseconds{8});
  ASSERT_TRUE(out);
  EXPECT_TRUE(wrench(*out).isApprox(narrow.hi, 1e-12)) << wrench(*out).transpose();
}

TEST_F(DriverNodeTest, DriverNode_InSc_FullLimitsLetMoreThanRestrictedThrough) {
  DriverNode driver = make(SrMode::SC);
  flight::InputVec u = limits_.u_hover;
  u[0] = limits_.restricted.hi[0] + 0.5 * (limits_.full.hi[0] - limits_.restricted.hi[0]);  // thrust beyond Ū
  const auto out = driver.on_controls(controls(u), milliseconds{4});
  ASSERT_TRUE(out);
  EXPECT_EQ(out->limits_restricted, 0);
  EXPECT_TRUE(wrench(*out).isApprox(u, 1e-12));
}

TEST_F(DriverNodeTest, DriverNode_ModeChange_SwitchesTheLimitSet) {
  DriverNode driver = make(SrMode::SC);
  EXPECT_EQ(driver.limits(), flight::LimitSet::Full);
  driver.on_mode(SrMode::MC);
  EXPECT_EQ(driver.limits(), flight::LimitSet::Restricted);
  for (const SrMode m : {SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP}) {
    driver.on_mode(m);
    EXPECT_EQ(driver.limits(), flight::LimitSet::Full) << to_string(m);
  }
}

TEST_F(DriverNodeTest, DriverNode_RotorSaturation_EachMotorStaysInZeroOne) {
  DriverNode driver = make(SrMode::SC);
  flight::InputVec u = limits_.full.hi;  // not reachable by four rotors at once
  const auto out = driver.on_controls(controls(u), milliseconds{4});
  ASSERT_TRUE(out);
  for (const double U : out->motor) {
    EXPECT_GE(U, 0.0);
    EXPECT_LE(U, 1.0);
  }
}

TEST_F(DriverNodeTest, DriverNode_NonFiniteControls_RefusedAndTheLastOutputsHeld) {
  DriverNode driver = make(SrMode::MC);
  const auto first = driver.on_controls(controls(limits_.u_hover), milliseconds{4});
  ASSERT_TRUE(first);
  rejuv_msg_ActuatorControls bad = controls(limits_.u_hover);
  bad.torque_B_N_m[1] = std::numeric_limits<double>::quiet_NaN();
  const auto r = driver.on_controls(bad, milliseconds{8});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, flight_io::InputError::NotFinite);
  EXPECT_TRUE(driver.driver().applied_u().isApprox(limits_.u_hover, 1e-12));
}

}  // namespace
}  // namespace rejuv::services
