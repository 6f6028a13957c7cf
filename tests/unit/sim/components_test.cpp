// The pieces of the model-level SR engine (docs/design.md §7–§8): the kernel's rejuvenation timer and image store, the
// rollback handler of §V-B/Fig. 6 with Taken/Restored, the output driver's limits, the estimator node's rollback.
#include <gtest/gtest.h>

#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight/output_driver.hpp"
#include "rejuv/flight/rollback_handler.hpp"
#include "rejuv/flight/sr_kernel_model.hpp"
#include "rejuv/plant/plant.hpp"

namespace rejuv::flight {
namespace {

using std::chrono::milliseconds;

// ---- RejuvenationTimer ----

TEST(RejuvenationTimer, Arm_SecondTimeInSameEpoch_Refused) {
  RejuvenationTimer timer;
  ASSERT_TRUE(timer.arm(Epoch{3}, Nanos{0}, milliseconds{300}).has_value());
  const auto again = timer.arm(Epoch{3}, milliseconds{10}, milliseconds{300});
  ASSERT_FALSE(again.has_value());
  EXPECT_EQ(again.error(), TimerError::AlreadyArmedThisEpoch);
  EXPECT_EQ(timer.refused(), 1U);
  EXPECT_EQ(timer.deadline(), Nanos{milliseconds{300}});  // the refused arm left no trace
}

TEST(RejuvenationTimer, Arm_NextEpoch_Accepted) {
  RejuvenationTimer timer;
  ASSERT_TRUE(timer.arm(Epoch{0}, Nanos{0}, milliseconds{300}).has_value());
  EXPECT_TRUE(timer.arm(Epoch{1}, milliseconds{100}, milliseconds{300}).has_value());
  EXPECT_EQ(timer.deadline(), Nanos{milliseconds{400}});
}

TEST(RejuvenationTimer, Arm_NonPositiveDuration_ReturnsBadDuration) {
  RejuvenationTimer timer;
  const auto r = timer.arm(Epoch{0}, Nanos{0}, Nanos{0});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), TimerError::BadDuration);
  EXPECT_FALSE(timer.armed());
}

TEST(RejuvenationTimer, FireIfDue_AtDeadline_FiresOnce) {
  RejuvenationTimer timer;
  ASSERT_TRUE(timer.arm(Epoch{0}, Nanos{0}, milliseconds{300}).has_value());
  EXPECT_FALSE(timer.fire_if_due(milliseconds{299}));
  EXPECT_TRUE(timer.fire_if_due(milliseconds{300}));
  EXPECT_FALSE(timer.fire_if_due(milliseconds{301}));
  EXPECT_FALSE(timer.armed());
}

// ---- ImageStore ----

TEST(ImageStore, Save_MoreThanK_KeepsNewestK) {
  ImageStore<int> store(2);
  EXPECT_EQ(store.latest(), nullptr);
  (void)store.save(10, Nanos{1});
  (void)store.save(20, Nanos{2});
  const Generation g3 = store.save(30, Nanos{3});
  EXPECT_EQ(store.size(), 2U);
  ASSERT_NE(store.latest(), nullptr);
  EXPECT_EQ(store.latest()->image, 30);
  EXPECT_EQ(store.latest()->generation, g3);
  EXPECT_EQ(g3.value(), 3U);
}

// ---- RollbackHandler (§V-B Fig. 5/6 with docs/design.md §7–§8) ----

class HandlerTest : public ::testing::Test {
 protected:
  HandlerTiming timing{.t_est = Seconds{3.0}, .t_min = Seconds{0.02}, .check_period = Seconds{0.002}, .rho_s = 0.0894};
  RollbackHandler handler{timing};
  int evaluations = 0;
  // A V̂ provider that counts how often the handler looks at the estimate.
  auto v_hat(double value) {
    return [this, value] {
      ++evaluations;
      return value;
    };
  }
};

TEST_F(HandlerTest, RollbackSignal_Any_EntersSafetyControl) {
  EXPECT_EQ(handler.on_rollback_signal(Nanos{0}), HandlerRequest::EnterSafetyControl);
  EXPECT_EQ(handler.phase(), RollbackHandler::Phase::WaitEst);
}

TEST_F(HandlerTest, Tick_BeforeTest_DoesNotLookAtTheEstimate) {
  (void)handler.on_rollback_signal(Nanos{0});
  for (Nanos t{0}; t < milliseconds{3000}; t += milliseconds{1}) {
    EXPECT_EQ(handler.tick(t, v_hat(0.0)), HandlerRequest::None);
  }
  EXPECT_EQ(evaluations, 0);
}

TEST_F(HandlerTest, Tick_AfterTestOutsideRhoS_KeepsCheckingEveryPeriod) {
  (void)handler.on_rollback_signal(Nanos{0});
  for (Nanos t = milliseconds{3000}; t < milliseconds{3100}; t += milliseconds{1}) {
    EXPECT_EQ(handler.tick(t, v_hat(0.0081)), HandlerRequest::None);  // ρ_s² = 0.00799
  }
  EXPECT_EQ(evaluations, 50);  // every 2 ms for 100 ms
  EXPECT_EQ(handler.phase(), RollbackHandler::Phase::Check);
}

TEST_F(HandlerTest, Tick_InsideRhoS_UpdatesThenCheckpointsAfterTmin) {
  (void)handler.on_rollback_signal(Nanos{0});
  EXPECT_EQ(handler.tick(milliseconds{3000}, v_hat(0.001)), HandlerRequest::UpdateSetpoint);
  EXPECT_EQ(handler.tick(milliseconds{3019}, v_hat(0.001)), HandlerRequest::None);
  EXPECT_EQ(handler.tick(milliseconds{3020}, v_hat(0.001)), HandlerRequest::Checkpoint);
  EXPECT_EQ(handler.phase(), RollbackHandler::Phase::InCheckpoint);
}

TEST_F(HandlerTest, CheckpointReturn_Taken_ArmsTimerAndEntersMission) {
  (void)handler.on_rollback_signal(Nanos{0});
  (void)handler.tick(milliseconds{3000}, v_hat(0.0));
  (void)handler.tick(milliseconds{3020}, v_hat(0.0));
  EXPECT_EQ(handler.on_checkpoint_return(CheckpointTaken{Generation{1}}), HandlerRequest::ArmTimerAndEnterMission);
  EXPECT_EQ(handler.phase(), RollbackHandler::Phase::Idle);
}

TEST_F(HandlerTest, CheckpointReturn_RestoredCopy_ExitsWithoutArming) {
  (void)handler.on_rollback_signal(Nanos{0});
  (void)handler.tick(milliseconds{3000}, v_hat(0.0));
  (void)handler.tick(milliseconds{3020}, v_hat(0.0));
  RollbackHandler image = handler;  // the checkpoint: the image's handler is inside checkpoint()
  (void)handler.on_checkpoint_return(CheckpointTaken{Generation{1}});
  // Later the image is restored: its old run returns Restored and must not arm the timer again (§V-C).
  EXPECT_EQ(image.on_checkpoint_return(CheckpointRestored{Generation{1}, Epoch{1}}), HandlerRequest::None);
  EXPECT_EQ(image.phase(), RollbackHandler::Phase::Idle);
  EXPECT_EQ(image.on_rollback_signal(milliseconds{3500}), HandlerRequest::EnterSafetyControl);
}

TEST_F(HandlerTest, CheckpointReturn_WhenNotInCheckpoint_Ignored) {
  EXPECT_EQ(handler.on_checkpoint_return(CheckpointTaken{Generation{1}}), HandlerRequest::None);
  EXPECT_EQ(handler.phase(), RollbackHandler::Phase::Idle);
}

// ---- OutputDriver (§IV-C) ----

class OutputDriverTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto d = design_control(ControlDesignSpec{});
    ASSERT_TRUE(d.has_value()) << d.error().to_string();
    design = std::make_unique<ControlDesign>(*d);
    const plant::Mixer mixer(plant::QuadParams::jmavsim_default());
    driver = std::make_unique<OutputDriver>(mixer.inverse(), design->full, design->restricted, design->u_hover);
  }
  std::unique_ptr<ControlDesign> design;
  std::unique_ptr<OutputDriver> driver;
};

TEST_F(OutputDriverTest, Publish_RestrictedLimits_ClampsToUbar) {
  driver->set_limits(LimitSet::Restricted);
  driver->publish(Nanos{0}, design->full.hi);
  EXPECT_TRUE(driver->applied_u().isApprox(design->restricted.hi));
}

TEST_F(OutputDriverTest, Publish_FullLimits_PassesLargeTorque) {
  driver->set_limits(LimitSet::Full);
  InputVec u = design->u_hover;
  u[1] = 0.3;
  driver->publish(Nanos{0}, u);
  EXPECT_NEAR(driver->applied_u()[1], 0.3, 1e-12);
  EXPECT_TRUE(((driver->motor_command().array() >= 0.0) && (driver->motor_command().array() <= 1.0)).all());
}

TEST_F(OutputDriverTest, Publish_Hover_MotorsAtHoverLevel) {
  driver->publish(Nanos{0}, design->u_hover);
  const double hover = plant::QuadParams::jmavsim_default().hover_level();
  EXPECT_TRUE(driver->motor_command().isApprox(Eigen::Vector4d::Constant(hover), 1e-9));
}

TEST_F(OutputDriverTest, Publish_Gaps_RecordsLongest) {
  driver->publish(milliseconds{0}, design->u_hover);
  driver->publish(milliseconds{4}, design->u_hover);
  driver->publish(milliseconds{27}, design->u_hover);
  driver->publish(milliseconds{31}, design->u_hover);
  EXPECT_EQ(driver->max_gap(), Nanos{milliseconds{23}});
}

// ---- EstimatorNode ----

TEST(EstimatorNode, OnRollback_KeepsTheRestoredEstimate) {
  const EkfState initial{.p_N_m = Eigen::Vector3d(1, 2, -3)};
  EstimatorNode node(EkfParams::defaults(), initial, milliseconds{4});
  const StateVec before = node.estimate();
  node.on_rollback(EkfRearm{});
  EXPECT_TRUE(node.estimate().isApprox(before));
  // ...with the re-armed uncertainty (position 1σ = 0.1 m).
  EXPECT_NEAR(node.ekf().covariance()(0, 0), 0.01, 1e-12);
}

TEST(EstimatorNode, OnSamples_NoGyro_NoNewEstimate) {
  EstimatorNode node(EkfParams::defaults(), EkfState{}, milliseconds{4});
  plant::SensorSamples samples;
  samples.baro = plant::BaroSample{.t = Nanos{0}, .altitude_m = 0.0, .pressure_pa = 101325.0};
  EXPECT_FALSE(node.on_samples(samples));
  samples.gyro = plant::GyroSample{};
  EXPECT_TRUE(node.on_samples(samples));
}

}  // namespace
}  // namespace rejuv::flight
