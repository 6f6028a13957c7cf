// The worst-case attack law of §VI-D: the chosen corner of Ū maximises V̇ = 2 eᵀP(Ae + Bδu) over all corners.
#include <gtest/gtest.h>

#include <random>

#include "rejuv/flight/attack.hpp"
#include "rejuv/flight/control_design.hpp"

namespace rejuv::flight {
namespace {

class AttackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto r = design_control(ControlDesignSpec{});
    ASSERT_TRUE(r.has_value()) << r.error().to_string();
    d_ = std::make_unique<ControlDesign>(*r);
  }
  std::unique_ptr<ControlDesign> d_;
};

TEST_F(AttackTest, WorstCaseCorner_RandomStates_MaximisesVdotOverAllCorners) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.05);
  for (int k = 0; k < 1000; ++k) {
    StateVec e;
    for (auto& v : e) v = n(rng);
    const InputVec chosen = worst_case_corner(d_->restricted, d_->ellipsoid.P(), d_->continuous.B, e);
    const double best = lyapunov_rate(d_->continuous, d_->ellipsoid.P(), e, chosen, d_->u_hover);
    for (const InputVec& corner : d_->restricted.corners()) {
      EXPECT_GE(best + 1e-12, lyapunov_rate(d_->continuous, d_->ellipsoid.P(), e, corner, d_->u_hover));
    }
  }
}

TEST_F(AttackTest, WorstCaseCorner_AnyState_IsACornerOfTheBox) {
  StateVec e = StateVec::Zero();
  e[idx::kAtt] = 0.02;
  const InputVec u = worst_case_corner(d_->restricted, d_->ellipsoid.P(), d_->continuous.B, e);
  for (Eigen::Index j = 0; j < kInputDim; ++j) {
    EXPECT_TRUE(u[j] == d_->restricted.lo[j] || u[j] == d_->restricted.hi[j]) << "component " << j;
  }
}

TEST_F(AttackTest, WorstCaseCorner_RolledRight_PushesRollFurther) {
  // A positive roll error is made worse by positive roll torque.
  StateVec e = StateVec::Zero();
  e[idx::kAtt + 0] = 0.05;
  const InputVec u = worst_case_corner(d_->restricted, d_->ellipsoid.P(), d_->continuous.B, e);
  EXPECT_EQ(u[1], d_->restricted.hi[1]);
}

}  // namespace
}  // namespace rejuv::flight
