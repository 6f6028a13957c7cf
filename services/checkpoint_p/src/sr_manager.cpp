#include "rejuv/services/checkpoint_p/sr_manager.hpp"

#include <limits>
#include <utility>
#include <variant>

#include "rejuv/flight/detail/printf.hpp"

namespace rejuv::services {

std::string_view to_string(SrManager::Phase phase) {
  switch (phase) {
    case SrManager::Phase::Idle: return "idle";
    case SrManager::Phase::Running: return "running";
    case SrManager::Phase::Mission: return "mission";
    case SrManager::Phase::AwaitRollback: return "await rollback";
  }
  return "unknown";
}

using flight::detail::printf_string;

SrManager::SrManager(const SrManagerConfig& config, const flight::SafetyEllipsoid& ellipsoid,
                     SrEffects& effects, std::optional<flight::StateVec> initial_setpoint)
    : config_(config),
      ellipsoid_(ellipsoid),
      effects_(&effects),
      handler_(config.cycle.handler_timing()),
      x_sp_(std::move(initial_setpoint)) {}

Result<void, flight_io::InputFailure> SrManager::on_state(const rejuv_msg_VehicleStateEstimate& message) {
  auto x_hat = flight_io::state_from_message(message);
  if (!x_hat) return fail(std::move(x_hat.error()));
  x_hat_ = *x_hat;
  return {};
}

Result<void, flight_io::InputFailure> SrManager::on_setpoint(const rejuv_msg_Setpoint& message) {
  auto x_sp = flight_io::setpoint_from_message(message);
  if (!x_sp) return fail(std::move(x_sp.error()));
  x_sp_ = *x_sp;
  return {};
}

std::optional<double> SrManager::V_hat() const {
  if (!x_hat_ || !x_sp_) return std::nullopt;
  return ellipsoid_.V(*x_hat_, *x_sp_);
}

void SrManager::start() {
  begin_run(effects_->epoch(), "boot");
}

void SrManager::on_rollback_signal(const rejuv_msg_RollbackSignal& message) {
  const Epoch epoch{message.epoch};
  if (run_epoch_ && epoch.value() <= run_epoch_->value()) {
    effects_->log(Severity::Debug,
                  printf_string("rollback_signal (g %llu, epoch %u): the run of this epoch has started",
                                static_cast<unsigned long long>(message.generation), message.epoch));
    return;
  }
  begin_run(epoch, "rollback_signal");
}

void SrManager::tick() {
  if (phase_ != Phase::Running) return;
  // (1) is evaluated only when due; before the first estimate it cannot hold.
  handle(handler_.tick(effects_->now(),
                       [this] { return V_hat().value_or(std::numeric_limits<double>::infinity()); }));
}

void SrManager::begin_run(Epoch epoch, std::string_view why) {
  run_epoch_ = epoch;
  phase_ = Phase::Running;
  effects_->log(Severity::Debug, printf_string("handler run (%.*s, epoch %u): set_SC_mode, wait T_est = %g s",
                                               static_cast<int>(why.size()), why.data(), epoch.value(),
                                               config_.cycle.t_est.count()));
  handle(handler_.on_rollback_signal(effects_->now()));
}

void SrManager::handle(flight::HandlerRequest request) {
  switch (request) {
    case flight::HandlerRequest::None: return;
    case flight::HandlerRequest::EnterSafetyControl: (void)switch_mode(SrMode::SC); return;
    case flight::HandlerRequest::UpdateSetpoint: request_update(); return;
    case flight::HandlerRequest::Checkpoint: take_checkpoint(); return;
    case flight::HandlerRequest::ArmTimerAndEnterMission: enter_mission(); return;
  }
}

bool SrManager::switch_mode(SrMode mode) {
  effects_->log(Severity::Debug, printf_string("mode -> %s", std::string(to_string(mode)).c_str()));
  if (auto ok = effects_->request_mode(mode); !ok) {
    problem(printf_string("request mode %s", std::string(to_string(mode)).c_str()), ok.error());
    return false;
  }
  return true;
}

void SrManager::problem(std::string_view what, const EffectFailure& failure) {
  ++failures_;
  effects_->log(Severity::Error, std::string(what) + ": " + failure.message);
}

void SrManager::request_update() {
  // publish_update_sp() of Fig. 5, in mode "update" of Fig. 1.
  effects_->log(Severity::Debug,
                printf_string("(1) holds: V_hat = %.6g < rho_s^2 = %.6g", V_hat().value_or(-1.0),
                              config_.cycle.tracking.rho_s * config_.cycle.tracking.rho_s));
  (void)switch_mode(SrMode::Update);
  rejuv_msg_SetpointUpdateRequest m{};
  m.timestamp_ns = flight_io::stamp(effects_->now());
  m.epoch = effects_->epoch().value();
  m.rho_m = config_.cycle.tracking.rho_M;
  if (auto ok = effects_->request_setpoint_update(m); !ok)
    problem("publish setpoint_update_request", ok.error());
}

void SrManager::take_checkpoint() {
  if (!switch_mode(SrMode::CP)) {
    // Without CP the kernel refuses the checkpoint anyway: start over in SC.
    begin_run(effects_->epoch(), "retry: CP refused");
    return;
  }
  auto result = effects_->checkpoint();
  if (!result) {
    problem("checkpoint", result.error());
    begin_run(effects_->epoch(), "retry: checkpoint failed");
    return;
  }
  if (const auto* taken = std::get_if<flight::CheckpointTaken>(&*result)) {
    ++taken_;
    effects_->log(Severity::Debug, printf_string("checkpoint g %llu taken",
                                                 static_cast<unsigned long long>(taken->generation.value())));
    handle(handler_.on_checkpoint_return(*result));
    return;
  }
  // Restored: a rollback resumed this image inside checkpoint() (mode RB). The old run ends here (Fig. 8's
  // "exit from rollback handler") and a new one starts: the timer may be armed once in the new epoch.
  const auto& restored = std::get<flight::CheckpointRestored>(*result);
  ++restored_;
  effects_->log(Severity::Debug, printf_string("restored from g %llu into epoch %u",
                                               static_cast<unsigned long long>(restored.generation.value()),
                                               restored.epoch.value()));
  (void)handler_.on_checkpoint_return(*result);  // None: the run of the old incarnation is over
  begin_run(restored.epoch, "restored");
}

void SrManager::enter_mission() {
  // do_timer(T_MC, 0) first: never MC without the rollback that ends it (§V-A).
  if (auto ok = effects_->arm_rejuvenation_timer(to_nanos(config_.cycle.t_mc)); !ok) {
    problem("arm the rejuvenation timer", ok.error());
    begin_run(effects_->epoch(), "retry: timer not armed");
    return;
  }
  effects_->log(Severity::Debug,
                printf_string("rejuvenation timer armed for T_MC = %g s", config_.cycle.t_mc.count()));
  // The limits Ū before the network comes on (§IV-C).
  if (auto ok =
          effects_->write_limits(flight_io::limits_record(config_.restricted, flight::LimitSet::Restricted));
      !ok) {
    problem("write the restricted limits", ok.error());
    (void)switch_mode(SrMode::SC);
    phase_ = Phase::AwaitRollback;  // the armed timer brings the rollback; SC until then
    return;
  }
  effects_->log(Severity::Debug, "restricted limits written");
  if (!switch_mode(SrMode::MC)) {
    (void)switch_mode(SrMode::SC);
    phase_ = Phase::AwaitRollback;
    return;
  }
  phase_ = Phase::Mission;
}

}  // namespace rejuv::services
