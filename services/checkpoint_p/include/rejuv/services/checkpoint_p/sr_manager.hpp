// The `checkpoint_p` service (paper §V-B Fig. 5, §V-C Fig. 6; docs/design.md §7–§8): the rollback handler of the
// SR scheme, the one service that switches modes, takes checkpoints, arms the rejuvenation timer and writes
// the actuator limits (the policy grants it all of that in the SEI only).
//
//   start / Restored:  request SC → wait T_est → every check_period: if ‖x̂ − x_sp‖_P < ρ_s:
//                      request UPDATE + publish setpoint_update_request → wait t_min → request CP →
//                      checkpoint() → Taken:    arm the timer once for T_MC, write Ū, request MC
//                                   → Restored: (this image was resumed by a rollback; mode RB) start again
//
// The timing and the check are the simulation's own flight::RollbackHandler (flight/sim), so that the
// process flies the reference's cycle; SrManager turns its requests into kernel calls through SrEffects
// (main.cpp: the SDK; tests: a recorder) and adds what a process needs:
//   * checkpoint() returns twice, like fork (docs/design.md §7): Taken in the live process, Restored in a resumed
//     image. No persistent semaphore (Fig. 6) is needed: the kernel refuses a second timer arm per epoch.
//   * rollback_signal (the kernel, after a rollback) also starts a run, unless the Restored return of the
//     same epoch has already started one (normally the case: every image of checkpoint_p is taken inside
//     checkpoint()). A cold restart of the graph boots into start().
//   * A failed kernel call never leads to MC: a failed checkpoint or timer arm goes back to SC and starts
//     the run again (T_est is the back-off); a failed limits write or MC request after the timer is armed
//     goes back to SC and waits for the rollback the timer will bring.
// Topics: in vehicle_state, setpoint (x_sp; until the first one, the mission's first waypoint, where the
// setpoint generator starts), rollback_signal; out setpoint_update_request (ρ_M = sr.rho_m).
// Params (graph-wide, flight_io/params.hpp): sr.enabled, sr.t_mc_s, sr.t_est_s, sr.rho_m, sr.rho_s,
// sr.t_min_s, sr.check_period_s, sr.box.*, sr.restricted_limit_fraction (P and Ū), mission.* (first x_sp).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/ellipsoid.hpp"
#include "rejuv/flight/limits.hpp"
#include "rejuv/flight/rollback_handler.hpp"
#include "rejuv/flight/sr_kernel_model.hpp"
#include "rejuv/flight_io/messages.hpp"
#include "rejuv/flight_io/params.hpp"

namespace rejuv::services {

// Why a kernel call of the handler failed (the SDK error as text: the manager only reports it).
struct EffectFailure {
  std::string message{};
};

enum class Severity : std::uint8_t { Debug, Info, Warn, Error };

// What the rollback handler asks of the kernel (§V: set_SC_mode, publish_update_sp, recreate_checkpoint,
// do_timer, the limits message, set_MC_mode) and where it logs. main.cpp implements it with the SDK.
class SrEffects {
 public:
  SrEffects() = default;
  SrEffects(const SrEffects&) = delete;
  SrEffects& operator=(const SrEffects&) = delete;
  virtual ~SrEffects() = default;

  // The kernel's clock and rollback epoch (the time page): read again after checkpoint() returns, which can
  // be much later (Restored).
  [[nodiscard]] virtual Nanos now() const = 0;
  [[nodiscard]] virtual Epoch epoch() const = 0;
  // ModeRequest on sr_mode_control (arg0 = the SrMode).
  virtual Result<void, EffectFailure> request_mode(SrMode mode) = 0;
  // Publish on setpoint_update_request.
  virtual Result<void, EffectFailure> request_setpoint_update(
      const rejuv_msg_SetpointUpdateRequest& message) = 0;
  // checkpoint(): returns Taken in the live process and Restored when a rollback resumed this image.
  virtual Result<flight::CheckpointReturn, EffectFailure> checkpoint() = 0;
  // TimerArm on checkpoint (arg0 = after [ns], arg1 = 0: once).
  virtual Result<void, EffectFailure> arm_rejuvenation_timer(Nanos after) = 0;
  // LimitsWrite on actuator_limits (data = the record's bytes).
  virtual Result<void, EffectFailure> write_limits(const flight_io::LimitsRecord& record) = 0;
  virtual void log(Severity severity, std::string_view text) = 0;
};

struct SrManagerConfig {
  flight_io::SrCycleParams cycle{};
  flight::InputBox restricted{};  // Ū, written before MC (§IV-C)
};

class SrManager {
 public:
  enum class Phase : std::uint8_t {
    Idle,           // not started (or SR is off)
    Running,        // a handler run: see handler().phase() (wait T_est, check (1), wait t_min)
    Mission,        // MC: the timer is armed; the next event is the rollback (Restored / rollback_signal)
    AwaitRollback,  // the timer is armed but MC could not be entered: safe in SC until the rollback
  };

  // `effects` must outlive the manager. `initial_setpoint`: x_sp until the first setpoint message.
  SrManager(const SrManagerConfig& config, const flight::SafetyEllipsoid& ellipsoid, SrEffects& effects,
            std::optional<flight::StateVec> initial_setpoint = std::nullopt);

  // Boot: the first cycle is a handler run without a rollback (as the simulation), so the first checkpoint
  // is taken in the same conditions as every later one.
  void start();
  // Call at least every check_period (main.cpp: a kernel timer of that period).
  void tick();
  // The kernel's RollbackSignal: starts a run unless one was already started for its epoch.
  void on_rollback_signal(const rejuv_msg_RollbackSignal& message);

  Result<void, flight_io::InputFailure> on_state(const rejuv_msg_VehicleStateEstimate& message);
  Result<void, flight_io::InputFailure> on_setpoint(const rejuv_msg_Setpoint& message);

  // V̂ = ‖x̂ − x_sp‖²_P, or nullopt before the first estimate or setpoint.
  [[nodiscard]] std::optional<double> V_hat() const;

  [[nodiscard]] Phase phase() const { return phase_; }
  [[nodiscard]] const flight::RollbackHandler& handler() const { return handler_; }
  [[nodiscard]] std::uint64_t checkpoints_taken() const { return taken_; }
  [[nodiscard]] std::uint64_t restores() const { return restored_; }
  [[nodiscard]] std::uint64_t failures() const { return failures_; }
  // The epoch the current (or last) run was started for.
  [[nodiscard]] std::optional<Epoch> run_epoch() const { return run_epoch_; }

 private:
  void begin_run(Epoch epoch, std::string_view why);
  void handle(flight::HandlerRequest request);
  void request_update();
  void take_checkpoint();
  void enter_mission();
  [[nodiscard]] bool switch_mode(SrMode mode);
  void problem(std::string_view what, const EffectFailure& failure);

  SrManagerConfig config_;
  flight::SafetyEllipsoid ellipsoid_;
  SrEffects* effects_;
  flight::RollbackHandler handler_;
  Phase phase_ = Phase::Idle;
  std::optional<flight::StateVec> x_hat_;
  std::optional<flight::StateVec> x_sp_;
  std::optional<Epoch> run_epoch_;
  std::uint64_t taken_ = 0;
  std::uint64_t restored_ = 0;
  std::uint64_t failures_ = 0;
};

[[nodiscard]] std::string_view to_string(SrManager::Phase phase);

}  // namespace rejuv::services
