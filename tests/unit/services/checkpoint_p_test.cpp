// checkpoint_p: the rollback handler's state machine against a recording fake of the kernel (no processes).
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <deque>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rejuv/flight/rollback_handler.hpp"
#include "rejuv/flight_io/params.hpp"
#include "rejuv/services/checkpoint_p/sr_manager.hpp"
#include "service_test_messages.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;
using testing::state_message;

// One kernel call the handler made.
struct Call {
  enum class Kind : std::uint8_t { Mode, Update, Checkpoint, Arm, Limits };
  Kind kind = Kind::Mode;
  Nanos at{0};
  SrMode mode = SrMode::MC;
  Nanos after{0};
  flight_io::LimitsRecord limits{};
  rejuv_msg_SetpointUpdateRequest update{};
};

// The kernel as the handler sees it: a clock, an epoch, and answers it can be told to refuse.
class FakeKernel final : public SrEffects {
 public:
  [[nodiscard]] Nanos now() const override { return t; }
  [[nodiscard]] Epoch epoch() const override { return e; }
  Result<void, EffectFailure> request_mode(SrMode m) override {
    calls.push_back(Call{.kind = Call::Kind::Mode, .at = t, .mode = m});
    if (refuse_mode == m) return fail(EffectFailure{.message = "denied"});
    mode = m;
    return {};
  }
  Result<void, EffectFailure> request_setpoint_update(const rejuv_msg_SetpointUpdateRequest& m) override {
    calls.push_back(Call{.kind = Call::Kind::Update, .at = t, .update = m});
    return {};
  }
  Result<flight::CheckpointReturn, EffectFailure> checkpoint() override {
    calls.push_back(Call{.kind = Call::Kind::Checkpoint, .at = t});
    if (!checkpoint_answers.empty()) {
      auto answer = std::move(checkpoint_answers.front());
      checkpoint_answers.pop_front();
      return answer;
    }
    generation = Generation{generation.value() + 1};
    return flight::CheckpointReturn{flight::CheckpointTaken{generation}};
  }
  Result<void, EffectFailure> arm_rejuvenation_timer(Nanos after) override {
    calls.push_back(Call{.kind = Call::Kind::Arm, .at = t, .after = after});
    if (refuse_arm) return fail(EffectFailure{.message = "operation failed: NotSupported"});
    return {};
  }
  Result<void, EffectFailure> write_limits(const flight_io::LimitsRecord& record) override {
    calls.push_back(Call{.kind = Call::Kind::Limits, .at = t, .limits = record});
    if (refuse_limits) return fail(EffectFailure{.message = "denied"});
    return {};
  }
  void log(Severity severity, std::string_view text) override {
    logs.emplace_back(severity, std::string(text));
  }

  [[nodiscard]] std::vector<Call::Kind> kinds() const {
    std::vector<Call::Kind> k;
    for (const Call& c : calls) k.push_back(c.kind);
    return k;
  }
  [[nodiscard]] std::size_t errors() const {
    std::size_t n = 0;
    for (const auto& [s, text] : logs) n += s == Severity::Error ? 1U : 0U;
    return n;
  }

  Nanos t{0};
  Epoch e{0};
  SrMode mode = SrMode::SC;
  Generation generation{0};
  std::deque<Result<flight::CheckpointReturn, EffectFailure>> checkpoint_answers;
  std::optional<SrMode> refuse_mode;
  bool refuse_arm = false;
  bool refuse_limits = false;
  std::vector<Call> calls;
  std::vector<std::pair<Severity, std::string>> logs;
};

using K = Call::Kind;

class SrManagerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const auto params = flight_io::Params::from_table({});
    auto d = flight_io::control_design(params);
    ASSERT_TRUE(d) << d.error().to_string();
    design_.emplace(std::move(*d));
    auto c = flight_io::sr_cycle_params(params);
    ASSERT_TRUE(c) << c.error().to_string();
    cycle_ = *c;
  }
  static void TearDownTestSuite() { design_.reset(); }

  void SetUp() override {
    ASSERT_TRUE(design_.has_value());
    manager_.emplace(SrManagerConfig{.cycle = cycle_, .restricted = design_->restricted}, design_->ellipsoid,
                     kernel_, x_sp_);
  }

  // Feeds x̂ = x_sp + offset and ticks every millisecond (as the simulation's physics step) for `duration`.
  void fly(Nanos duration, const flight::StateVec& offset = flight::StateVec::Zero()) {
    const Nanos end = kernel_.t + duration;
    while (kernel_.t < end) {
      kernel_.t += milliseconds{1};
      ASSERT_TRUE(manager_->on_state(state_message(x_sp_ + offset, kernel_.t)));
      manager_->tick();
    }
  }
  [[nodiscard]] static Nanos t_est() { return to_nanos(cycle_.t_est); }
  [[nodiscard]] static Nanos t_min() { return to_nanos(cycle_.tracking.t_min); }

  static inline std::optional<flight::ControlDesign> design_;
  static inline flight_io::SrCycleParams cycle_{};
  const flight::StateVec x_sp_ = flight::hover_setpoint({0, 0, -3}, 0);
  FakeKernel kernel_;
  std::optional<SrManager> manager_;
};

TEST_F(SrManagerTest, SrManager_Start_RequestsSafetyControlOnly) {
  manager_->start();
  ASSERT_EQ(kernel_.kinds(), std::vector<K>{K::Mode});
  EXPECT_EQ(kernel_.calls[0].mode, SrMode::SC);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Running);
}

TEST_F(SrManagerTest, SrManager_BeforeTest_NoCheckEvenAtTheSetpoint) {
  manager_->start();
  fly(t_est() - milliseconds{1});
  EXPECT_EQ(kernel_.kinds(), std::vector<K>{K::Mode}) << "T_est is waited before (1) is checked (§IV-A)";
}

TEST_F(SrManagerTest, SrManager_ConditionHolds_FullCycleInTheOrderOfFig5) {
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  ASSERT_EQ(kernel_.kinds(), (std::vector<K>{K::Mode, K::Mode, K::Update, K::Mode, K::Checkpoint, K::Arm,
                                             K::Limits, K::Mode}));
  const auto& c = kernel_.calls;
  EXPECT_EQ(c[1].mode, SrMode::Update);
  EXPECT_EQ(c[1].at, t_est()) << "(1) checked as soon as T_est has passed";
  EXPECT_DOUBLE_EQ(c[2].update.rho_m, cycle_.tracking.rho_M);
  EXPECT_EQ(c[3].mode, SrMode::CP);
  EXPECT_GE(c[3].at - c[1].at, t_min()) << "t_min between the update and the checkpoint";
  EXPECT_EQ(c[5].after, to_nanos(cycle_.t_mc)) << "do_timer(T_MC, 0)";
  EXPECT_EQ(c[7].mode, SrMode::MC);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Mission);
  EXPECT_EQ(manager_->checkpoints_taken(), 1U);
  EXPECT_EQ(kernel_.errors(), 0U);
}

TEST_F(SrManagerTest, SrManager_Taken_WritesTheRestrictedLimitsOfTheDesign) {
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  ASSERT_EQ(kernel_.calls.size(), 8U);
  const Call& limits = kernel_.calls[6];
  ASSERT_EQ(limits.kind, K::Limits);
  const auto bytes = flight_io::limits_bytes(limits.limits);
  const auto decoded = flight_io::limits_from_bytes(bytes);
  ASSERT_TRUE(decoded) << decoded.error().to_string();
  EXPECT_EQ(decoded->set, flight::LimitSet::Restricted);
  EXPECT_EQ(decoded->box.lo, design_->restricted.lo);
  EXPECT_EQ(decoded->box.hi, design_->restricted.hi);
}

TEST_F(SrManagerTest, SrManager_SameInputs_UpdatesWhenTheSimulationsHandlerDoes) {
  // The reference: the model-level handler of flight/sim, fed the same V̂ at the same instants.
  flight::StateVec offset = flight::StateVec::Zero();
  offset[0] = 0.01;
  flight::RollbackHandler reference(cycle_.handler_timing());
  (void)reference.on_rollback_signal(Nanos{0});
  std::optional<Nanos> reference_update;
  const double V = design_->ellipsoid.V(x_sp_ + offset, x_sp_);
  for (Nanos t{0}; t <= t_est() + milliseconds{20} && !reference_update; t += milliseconds{1}) {
    if (reference.tick(t, [V] { return V; }) == flight::HandlerRequest::UpdateSetpoint) reference_update = t;
  }
  ASSERT_TRUE(reference_update.has_value());
  manager_->start();
  fly(t_est() + milliseconds{20}, offset);
  ASSERT_GE(kernel_.calls.size(), 2U);
  EXPECT_EQ(kernel_.calls[1].at, *reference_update);
  ASSERT_TRUE(manager_->V_hat().has_value());
  EXPECT_NEAR(*manager_->V_hat(), V, 1e-12) << "V̂ = ‖x̂ − x_sp‖²_P with the design's P";
}

TEST_F(SrManagerTest, SrManager_OutsideRhoS_StaysInSafetyControl) {
  flight::StateVec offset = flight::StateVec::Zero();
  offset[0] = 0.5;  // far outside E(ρ_s)
  ASSERT_GT(design_->ellipsoid.V(x_sp_ + offset, x_sp_), cycle_.tracking.rho_s * cycle_.tracking.rho_s);
  manager_->start();
  fly(t_est() + milliseconds{500}, offset);
  EXPECT_EQ(kernel_.kinds(), std::vector<K>{K::Mode});
}

TEST_F(SrManagerTest, SrManager_NoEstimateYet_ConditionCannotHold) {
  manager_->start();
  for (int i = 0; i < 4000; ++i) {
    kernel_.t += milliseconds{1};
    manager_->tick();
  }
  EXPECT_EQ(kernel_.kinds(), std::vector<K>{K::Mode});
  EXPECT_FALSE(manager_->V_hat().has_value());
}

TEST_F(SrManagerTest, SrManager_Restored_StartsANewRunFromSafetyControlWithoutArmingTheTimer) {
  kernel_.checkpoint_answers.emplace_back(
      flight::CheckpointReturn{flight::CheckpointRestored{Generation{1}, Epoch{1}}});
  manager_->start();
  kernel_.e = Epoch{1};  // the image resumes in the epoch of the rollback
  fly(t_est() + t_min() + milliseconds{10});
  ASSERT_GE(kernel_.calls.size(), 6U);
  EXPECT_EQ(kernel_.calls[4].kind, K::Checkpoint);
  EXPECT_EQ(kernel_.calls[5].kind, K::Mode);
  EXPECT_EQ(kernel_.calls[5].mode, SrMode::SC) << "the old run ends; the new one starts with set_SC_mode";
  for (const Call& c : kernel_.calls) EXPECT_NE(c.kind, K::Arm);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Running);
  EXPECT_EQ(manager_->restores(), 1U);
  ASSERT_TRUE(manager_->run_epoch().has_value());
  EXPECT_EQ(*manager_->run_epoch(), Epoch{1});
}

TEST_F(SrManagerTest, SrManager_RestoredThenItsCycle_TakenArmsTheTimerOnce) {
  kernel_.checkpoint_answers.emplace_back(
      flight::CheckpointReturn{flight::CheckpointRestored{Generation{1}, Epoch{1}}});
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  kernel_.calls.clear();
  fly(t_est() + t_min() + milliseconds{10});
  EXPECT_EQ(kernel_.kinds(),
            (std::vector<K>{K::Mode, K::Update, K::Mode, K::Checkpoint, K::Arm, K::Limits, K::Mode}));
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Mission);
}

TEST_F(SrManagerTest, SrManager_RollbackSignalOfTheRestoredEpoch_Ignored) {
  kernel_.checkpoint_answers.emplace_back(
      flight::CheckpointReturn{flight::CheckpointRestored{Generation{1}, Epoch{1}}});
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  const std::size_t before = kernel_.calls.size();
  rejuv_msg_RollbackSignal signal{};
  signal.generation = 1;
  signal.epoch = 1;
  manager_->on_rollback_signal(signal);
  EXPECT_EQ(kernel_.calls.size(), before) << "Restored already started the run of epoch 1";
}

TEST_F(SrManagerTest, SrManager_RollbackSignalOfANewEpoch_StartsARun) {
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  ASSERT_EQ(manager_->phase(), SrManager::Phase::Mission);
  kernel_.calls.clear();
  rejuv_msg_RollbackSignal signal{};
  signal.generation = 1;
  signal.epoch = 1;
  manager_->on_rollback_signal(signal);
  ASSERT_EQ(kernel_.kinds(), std::vector<K>{K::Mode});
  EXPECT_EQ(kernel_.calls[0].mode, SrMode::SC);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Running);
}

TEST_F(SrManagerTest, SrManager_CheckpointFails_BackToSafetyControlNoTimerNoMission) {
  kernel_.checkpoint_answers.emplace_back(fail(EffectFailure{.message = "operation failed: NotSupported"}));
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  EXPECT_EQ(kernel_.kinds(), (std::vector<K>{K::Mode, K::Mode, K::Update, K::Mode, K::Checkpoint, K::Mode}));
  EXPECT_EQ(kernel_.calls.back().mode, SrMode::SC);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Running) << "the run starts again (T_est is the back-off)";
  EXPECT_EQ(manager_->failures(), 1U);
  EXPECT_EQ(kernel_.errors(), 1U);
}

TEST_F(SrManagerTest, SrManager_TimerArmRefused_NeverEntersMission) {
  kernel_.refuse_arm = true;
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  EXPECT_EQ(kernel_.kinds(),
            (std::vector<K>{K::Mode, K::Mode, K::Update, K::Mode, K::Checkpoint, K::Arm, K::Mode}));
  EXPECT_EQ(kernel_.calls.back().mode, SrMode::SC);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::Running);
  EXPECT_EQ(kernel_.errors(), 1U);
}

TEST_F(SrManagerTest, SrManager_LimitsWriteRefused_WaitsForTheRollbackInSafetyControl) {
  kernel_.refuse_limits = true;
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  EXPECT_EQ(kernel_.kinds(), (std::vector<K>{K::Mode, K::Mode, K::Update, K::Mode, K::Checkpoint, K::Arm,
                                             K::Limits, K::Mode}));
  EXPECT_EQ(kernel_.calls.back().mode, SrMode::SC) << "no MC without Ū";
  EXPECT_EQ(manager_->phase(), SrManager::Phase::AwaitRollback);
  const std::size_t before = kernel_.calls.size();
  fly(t_est() + milliseconds{100});
  EXPECT_EQ(kernel_.calls.size(), before) << "the armed timer brings the rollback; nothing until then";
}

TEST_F(SrManagerTest, SrManager_MissionModeRefused_WaitsForTheRollbackInSafetyControl) {
  kernel_.refuse_mode = SrMode::MC;
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  EXPECT_EQ(kernel_.calls.back().mode, SrMode::SC);
  EXPECT_EQ(kernel_.mode, SrMode::SC);
  EXPECT_EQ(manager_->phase(), SrManager::Phase::AwaitRollback);
  EXPECT_EQ(manager_->failures(), 1U);
}

TEST_F(SrManagerTest, SrManager_Mission_TicksMakeNoKernelCalls) {
  manager_->start();
  fly(t_est() + t_min() + milliseconds{10});
  ASSERT_EQ(manager_->phase(), SrManager::Phase::Mission);
  const std::size_t before = kernel_.calls.size();
  fly(milliseconds{300});
  EXPECT_EQ(kernel_.calls.size(), before) << "in MC checkpoint_p holds none of its kernel caps (§IV-C)";
}

TEST_F(SrManagerTest, SrManager_SetpointMessage_IsTheCenterOfTheCheck) {
  const flight::StateVec moved = flight::hover_setpoint({0.3, 0, -3}, 0);
  ASSERT_TRUE(manager_->on_setpoint(flight_io::setpoint_message(moved, milliseconds{1}, 1, false)));
  ASSERT_TRUE(manager_->on_state(state_message(moved, milliseconds{2})));
  ASSERT_TRUE(manager_->V_hat().has_value());
  EXPECT_NEAR(*manager_->V_hat(), 0.0, 1e-18);
}

}  // namespace
}  // namespace rejuv::services
