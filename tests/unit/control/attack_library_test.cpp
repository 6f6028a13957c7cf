// The laws of the attack library (flight/attack_library.hpp; docs/control.md "Attack library"): each kind's
// corruption as the model and the runtime hooks compute it, and the names `--attack` and the loader use.
#include <gtest/gtest.h>

#include <random>

#include "rejuv/flight/attack_library.hpp"
#include "rejuv/flight/control_design.hpp"

namespace rejuv::flight {
namespace {

class AttackLibraryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto r = design_control(ControlDesignSpec{});
    ASSERT_TRUE(r.has_value()) << r.error().to_string();
    d_ = std::make_unique<ControlDesign>(*r);
  }
  // V̈ at e = 0 when the honest (unsaturated) controller acts on x̂ = x + δ: 2 δᵀKᵀBᵀPBKδ.
  [[nodiscard]] double v_ddot(const StateVec& delta) const {
    const StateVec e_dot = -d_->continuous.B * (d_->mission.K() * delta);
    return 2.0 * e_dot.dot(d_->ellipsoid.P() * e_dot);
  }
  std::unique_ptr<ControlDesign> d_;
};

TEST_F(AttackLibraryTest, FdiDirection_UnitPNormAndFastestOverRandomDirections) {
  const StateVec d = fdi_direction(*d_);
  EXPECT_NEAR(d_->ellipsoid.V(d, StateVec::Zero()), 1.0, 1e-9);
  const double best = v_ddot(d);
  EXPECT_GT(best, 0.0);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    StateVec r;
    for (auto& v : r) v = n(rng);
    r /= std::sqrt(r.dot(d_->ellipsoid.P() * r));  // ‖r‖_P = 1
    EXPECT_LE(v_ddot(r), best * (1.0 + 1e-9));
  }
}

TEST_F(AttackLibraryTest, FdiDirection_HonestLinearLoopSettlesFarOutsideTheSafetySet) {
  // x̂ = x + m d and the honest unsaturated discrete loop e⁺ = A e − B K (e + m d) settles at the fixed point
  // e* = −(I − A + BK)⁻¹ BK m d; d is not an equilibrium direction of the open loop, so e* ≠ −m d and V(e*) is
  // far larger than m² (the model's and the runtime's no-SR runs are lost within ≈ 2 s).
  const StateVec d = fdi_direction(*d_);
  const double m = 2.0;
  const StateMat I = StateMat::Identity();
  const StateMat BK = d_->discrete.B * d_->mission.K();
  const StateVec fixed = -(I - d_->discrete.A + BK).colPivHouseholderQr().solve(BK * (m * d));
  StateVec e = StateVec::Zero();
  for (int k = 0; k < 200000; ++k) e = d_->discrete.A * e - BK * (e + m * d);
  EXPECT_TRUE(e.isApprox(fixed, 1e-6));
  EXPECT_GT(d_->ellipsoid.V(e, StateVec::Zero()), m * m);
}

TEST_F(AttackLibraryTest, EstimateOffset_ShiftConstantDriftGrowsOthersZero) {
  const StateVec d = fdi_direction(*d_);
  EXPECT_TRUE(estimate_offset(AttackLaw::EstimateShift, d, 2.0, Seconds{0.0}).isApprox(2.0 * d));
  EXPECT_TRUE(estimate_offset(AttackLaw::EstimateShift, d, 2.0, Seconds{5.0}).isApprox(2.0 * d));
  EXPECT_TRUE(estimate_offset(AttackLaw::EstimateDrift, d, 0.2, Seconds{0.0}).isZero());
  EXPECT_TRUE(estimate_offset(AttackLaw::EstimateDrift, d, 0.2, Seconds{3.0}).isApprox(0.6 * d));
  for (const AttackLaw other : {AttackLaw::WorstCaseControl, AttackLaw::SensorBias, AttackLaw::SetpointShift,
                                AttackLaw::GainOverwrite}) {
    EXPECT_TRUE(estimate_offset(other, d, 2.0, Seconds{1.0}).isZero()) << to_string(other);
  }
}

TEST_F(AttackLibraryTest, GyroBiasSetpointOffsetAndGain_AsDocumented) {
  EXPECT_TRUE(gyro_bias(0.05).isApprox(Eigen::Vector3d(0.05, 0.0, 0.0)));
  const StateVec sp = setpoint_offset(0.5, Seconds{2.0});
  EXPECT_DOUBLE_EQ(sp[idx::kPos + 2], 1.0);  // NED: 1 m down
  EXPECT_DOUBLE_EQ(sp.norm(), 1.0);
  const GainMat K = d_->mission.K();
  EXPECT_TRUE(overwritten_gain(K, 1.0).isApprox(-K));
  EXPECT_TRUE(overwritten_gain(K, 3.0).isApprox(-3.0 * K));
  // The overwritten controller: positive feedback, still clamped to the controller's box.
  const LqrController bad = d_->mission.with_gain(overwritten_gain(K, 1.0));
  StateVec e = StateVec::Zero();
  e[idx::kPos] = 0.01;
  EXPECT_TRUE((bad.unclamped(e, StateVec::Zero()) - d_->u_hover).isApprox(-(d_->mission.unclamped(e, StateVec::Zero()) - d_->u_hover)));
  EXPECT_TRUE(d_->mission.limits().contains(bad.control(1e3 * e, StateVec::Zero()), 1e-12));
}

TEST(AttackLaw, Names_RoundTripCaseInsensitiveAndUnknown) {
  for (const AttackLaw law : kAllAttackLaws) {
    EXPECT_EQ(attack_law_from_name(to_string(law)), law);
    EXPECT_EQ(attack_law_from_number(proto_number(law)), law);
    EXPECT_FALSE(default_service(law).empty());
  }
  EXPECT_EQ(attack_law_from_name_icase("estimate_shift"), AttackLaw::EstimateShift);
  EXPECT_EQ(attack_law_from_name_icase("Gain_Overwrite"), AttackLaw::GainOverwrite);
  EXPECT_EQ(attack_law_from_name("estimate_shift"), std::nullopt);  // the exact form is the proto's
  EXPECT_EQ(attack_law_from_name_icase("FLOOD_BROKER"), std::nullopt);  // a runtime attack, not a law
  EXPECT_EQ(attack_law_from_number(11), std::nullopt);
  EXPECT_EQ(attack_law_names(),
            "WORST_CASE_CONTROL, ESTIMATE_SHIFT, SENSOR_BIAS, SETPOINT_SHIFT, GAIN_OVERWRITE, ESTIMATE_DRIFT");
  EXPECT_DOUBLE_EQ(effective_magnitude(AttackLaw::EstimateShift, 0.0), default_magnitude(AttackLaw::EstimateShift));
  EXPECT_DOUBLE_EQ(effective_magnitude(AttackLaw::EstimateShift, 5.0), 5.0);
}

}  // namespace
}  // namespace rejuv::flight
