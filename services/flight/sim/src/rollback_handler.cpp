#include "rejuv/flight/rollback_handler.hpp"

#include <type_traits>

namespace rejuv::flight {

std::string to_string(HandlerRequest request) {
  switch (request) {
    case HandlerRequest::None: return "none";
    case HandlerRequest::EnterSafetyControl: return "set_SC_mode";
    case HandlerRequest::UpdateSetpoint: return "publish_update_sp";
    case HandlerRequest::Checkpoint: return "recreate_checkpoint";
    case HandlerRequest::ArmTimerAndEnterMission: return "do_timer+set_MC_mode";
  }
  return "unknown";
}

std::string to_string(RollbackHandler::Phase phase) {
  switch (phase) {
    case RollbackHandler::Phase::Idle: return "idle";
    case RollbackHandler::Phase::WaitEst: return "wait T_est";
    case RollbackHandler::Phase::Check: return "check (1)";
    case RollbackHandler::Phase::WaitTmin: return "wait t_min";
    case RollbackHandler::Phase::InCheckpoint: return "in checkpoint";
  }
  return "unknown";
}

HandlerRequest RollbackHandler::on_rollback_signal(Nanos now) {
  // A new handler run starts whatever the previous one was doing (it belonged to a dead incarnation).
  phase_ = Phase::WaitEst;
  until_ = now + to_nanos(timing_.t_est);
  return HandlerRequest::EnterSafetyControl;
}

bool RollbackHandler::check_due(Nanos now) const {
  switch (phase_) {
    case Phase::WaitEst: return now >= until_;
    case Phase::Check: return now >= next_check_;
    case Phase::Idle:
    case Phase::WaitTmin:
    case Phase::InCheckpoint:
      return false;
  }
  return false;
}

HandlerRequest RollbackHandler::tick_checked(Nanos now, double V_hat) {
  switch (phase_) {
    case Phase::Idle:
    case Phase::InCheckpoint:
      return HandlerRequest::None;
    case Phase::WaitEst:
      if (now < until_) return HandlerRequest::None;
      phase_ = Phase::Check;
      next_check_ = now;
      [[fallthrough]];
    case Phase::Check:
      if (now < next_check_) return HandlerRequest::None;
      next_check_ += to_nanos(timing_.check_period);
      // (1): ‖x̂ − x_sp‖_P < ρ_s, compared squared.
      if (V_hat == kNotEvaluated || !(V_hat < timing_.rho_s * timing_.rho_s)) return HandlerRequest::None;
      phase_ = Phase::WaitTmin;
      until_ = now + to_nanos(timing_.t_min);
      return HandlerRequest::UpdateSetpoint;
    case Phase::WaitTmin:
      if (now < until_) return HandlerRequest::None;
      phase_ = Phase::InCheckpoint;
      return HandlerRequest::Checkpoint;
  }
  return HandlerRequest::None;
}

HandlerRequest RollbackHandler::on_checkpoint_return(const CheckpointReturn& result) {
  if (phase_ != Phase::InCheckpoint) return HandlerRequest::None;
  phase_ = Phase::Idle;
  // Taken: this is the live run, it arms the timer and hands over to MC. Restored: an old run resumed inside a
  // restored image; it simply exits (Fig. 8's "Exit from rollback handler"), the rollback signal starts anew.
  return std::holds_alternative<CheckpointTaken>(result) ? HandlerRequest::ArmTimerAndEnterMission
                                                         : HandlerRequest::None;
}

}  // namespace rejuv::flight
