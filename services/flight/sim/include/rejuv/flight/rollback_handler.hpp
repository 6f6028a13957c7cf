// The rollback handler of `checkpoint_p` (§V-B Fig. 5, §V-C Fig. 6) at the model level, with the
// improvements of docs/design.md §7–§8: checkpoint() returns Taken or Restored like fork, and the kernel refuses a
// second timer arm in one epoch, so no persistent Semaphore is needed.
//
//   on rollback signal: set_SC_mode → wait T_est → every check_period: if ‖x̂ − x_sp‖_P < ρ_s:
//   publish_update_sp → wait t_min → checkpoint → Taken: arm timer T_MC, limits Ū, set_MC_mode
//                                                → Restored: leave (the old handler instance exits)
//
// The blocking sleeps of Fig. 5 become phases of a small state machine that the engine ticks; each call returns
// what the handler asks of the kernel. It is a copyable value because it is part of the software image: a
// restored image finds its handler inside checkpoint() and gets Restored.
#pragma once

#include <cstdint>
#include <string>

#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/flight/sr_kernel_model.hpp"

namespace rejuv::flight {

struct HandlerTiming {
  // The defaults are the graph-wide keys' (rejuv/core/graph_values.hpp).
  Seconds t_est = to_seconds(graph_values::kTest.fallback);  // time in SC before the first check of (1), §V-B
  Seconds t_min = to_seconds(graph_values::kTmin.fallback);  // wait after the setpoint update before the checkpoint
  Seconds check_period = to_seconds(graph_values::kCheckPeriod.fallback);  // §V-B: "after every 2 ms"
  double rho_s = graph_values::kRhoS.fallback;  // the switching condition (1): ‖x̂ − x_sp‖_P < ρ_s
};

// What the handler asks for, in the words of Fig. 5.
enum class HandlerRequest : std::uint8_t {
  None,
  EnterSafetyControl,       // set_SC_mode(): network off, full limits, safety controller publishes
  UpdateSetpoint,           // publish_update_sp(): gen_set_point moves x_sp (mode "update" of Fig. 1)
  Checkpoint,               // recreate_checkpoint()
  ArmTimerAndEnterMission,  // do_timer(T_MC, 0), limits Ū, set_MC_mode()
};
[[nodiscard]] std::string to_string(HandlerRequest request);

class RollbackHandler {
 public:
  enum class Phase : std::uint8_t { Idle, WaitEst, Check, WaitTmin, InCheckpoint };

  explicit RollbackHandler(const HandlerTiming& timing) : timing_(timing) {}

  // The kernel delivered RollbackSignal (also used at boot: the first cycle is a rollback cycle without a
  // rollback, so the first checkpoint is taken in the same conditions as every later one).
  [[nodiscard]] HandlerRequest on_rollback_signal(Nanos now);
  // Called at least every check_period; `V_hat()` gives the latest V̂ = ‖x̂ − x_sp‖²_P and is evaluated only
  // when the check of (1) is due.
  template <class VHat>
  [[nodiscard]] HandlerRequest tick(Nanos now, VHat&& V_hat) {
    return check_due(now) ? tick_checked(now, V_hat()) : tick_checked(now, kNotEvaluated);
  }
  // checkpoint() returned.
  [[nodiscard]] HandlerRequest on_checkpoint_return(const CheckpointReturn& result);

  [[nodiscard]] Phase phase() const { return phase_; }
  [[nodiscard]] const HandlerTiming& timing() const { return timing_; }

 private:
  static constexpr double kNotEvaluated = -1.0;
  [[nodiscard]] bool check_due(Nanos now) const;
  [[nodiscard]] HandlerRequest tick_checked(Nanos now, double V_hat);

  HandlerTiming timing_;
  Phase phase_ = Phase::Idle;
  Nanos until_{0};
  Nanos next_check_{0};
};

[[nodiscard]] std::string to_string(RollbackHandler::Phase phase);

}  // namespace rejuv::flight
