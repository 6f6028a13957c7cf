// The model-level SR simulation behind `rejuv sim` (docs/design.md §8–§9): one process, no runtime. The plant runs at
// 1 kHz (RK4); sensors → EKF → controller at the IMU rate → output driver (limits, inverse mixer) → rotors.
// With SR on, the modes of Fig. 1 cycle MC (T_MC) → RB (T_RB, controls held, then the software image of the
// last checkpoint is restored while the plant kept moving) → SC (safety controller, full limits, T_est, then
// the check of (1) every check_period) → update (setpoint update of §IV-A, t_min) → CP (T_CP, controls held)
// → MC. With SR off the same tracking algorithm runs in MC forever (Table I's configurations "implement the
// same tracking algorithm"): the setpoint advances by the same rule whenever ‖x̂ − x_sp‖_P < ρ_s.
// Attacks (§VI-D): the compromised mission controller publishes the corner of Ū that maximises V̇ from the
// start of every MC window (without SR: from the first and for ever); or another kind of the attack library
// (attack_library.hpp: a shifted or drifting estimate, a biased gyro, a moving setpoint, an overwritten gain),
// each as the runtime's hook in the compromised service does it, erased by the rollback with the image.
//
// This engine is the reference the multi-process runtime is compared with: each piece (handler, kernel timer
// and image store, output driver, estimator node, setpoint generator, controllers) is its own type.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/core/sr_event.hpp"
#include "rejuv/textproto/textproto.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/attack_library.hpp"
#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight/ekf.hpp"
#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight/rollback_handler.hpp"
#include "rejuv/flight/setpoint.hpp"
#include "rejuv/flight/sim_config.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/plant/plant.hpp"
#include "summary.pb.h"

namespace rejuv::flight {

// Command-line overrides of the launch file (`--no-sr`, `--no-attack`, `--seed`).
struct SimOverrides {
  std::optional<SrSwitch> sr = std::nullopt;
  std::optional<AttackSwitch> attack = std::nullopt;
  std::optional<std::uint64_t> seed = std::nullopt;
  // T_CP and T_RB (SimConfig: the paper's 20 and 15 ms unless set), e.g. the runtime's lockstep charges for a
  // like-for-like comparison (`rejuv sweep --charges runtime`).
  std::optional<Seconds> t_cp = std::nullopt;
  std::optional<Seconds> t_rb = std::nullopt;
};

// Fills a SimConfig from a loaded launch graph and checks what the engine needs beyond load_launch's checks
// (the control design must succeed, e.g. Ū must be reachable by the rotors), with file:line:column errors.
[[nodiscard]] Result<SimConfig, LoadError> config_from_launch(const launch::LoadedLaunch& launch,
                                                              const SimOverrides& overrides);

// One row of the trace (one per control period of simulated time, whatever the mode).
struct TraceRow {
  Nanos t{0};
  StateVec x;      // true state
  StateVec x_hat;  // the live estimate (stale while the software is stopped in RB/CP)
  StateVec x_sp;   // the live setpoint
  SrMode mode = SrMode::MC;
  InputVec u;      // controls applied by the output driver
  double V = 0;    // ‖x − x_sp‖²_P (true state)
  double est_err = 0;  // ‖x − x̂‖²_P: the estimation error (§VI-D, Fig. 11(b))
};

struct ProgressReport {
  Seconds sim_time{0};
  Seconds wall_time{0};
  SrMode mode = SrMode::MC;
  double path_progress = 0;  // fraction of the path the setpoint has covered, 0..1
  std::uint64_t rollbacks = 0;
  double max_V = 0;
  bool final = false;  // the run is over (one such report per run)
};

struct SimObservers {
  std::function<void(const TraceRow&)> trace;
  std::function<void(const ProgressReport&)> progress;
  // Fig. 7: every control update (the output driver's publication) at simulated time t, real time `wall`
  // since the run was created; Fig. 8: what the SR cycle did (the same events as the runtime's kernel
  // reports; span = T_CP / T_RB, the model's charge). Events of the boot cycle come with the first step.
  std::function<void(Nanos t, Nanos wall)> control_update;
  std::function<void(const SrEvent&)> sr_event;
  Seconds progress_every{10.0};  // simulated time between progress reports
};

enum class SimError : std::uint8_t { Design, Config, Diverged };
struct SimFailure {
  SimError kind;
  std::string message;
  [[nodiscard]] std::string to_string() const;
};

// The engine, stepwise (tests inspect it between steps). A run: create, then step() until finished().
class SrSimulation {
 public:
  [[nodiscard]] static Result<SrSimulation, SimFailure> create(const SimConfig& config);
  SrSimulation(SrSimulation&&) noexcept;
  SrSimulation& operator=(SrSimulation&&) noexcept;
  ~SrSimulation();

  // One physics step. Returns false once the run is over (mission completed, timeout or vehicle lost).
  bool step(const SimObservers& observers = {});
  [[nodiscard]] bool finished() const;

  [[nodiscard]] Nanos now() const;
  [[nodiscard]] SrMode mode() const;
  [[nodiscard]] const StateVec& estimate() const;
  // x̂ as ekf2 publishes it: estimate(), shifted while a compromised ekf2 attacks (attack_library.hpp).
  [[nodiscard]] StateVec published_estimate() const;
  [[nodiscard]] const StateVec& setpoint() const;
  [[nodiscard]] StateVec truth() const;
  [[nodiscard]] const ControlDesign& design() const;
  // The summary so far (final once finished()). wall time is measured from create().
  [[nodiscard]] proto::RunSummary summary() const;

 private:
  struct Impl;
  explicit SrSimulation(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// create + step to the end + summary.
[[nodiscard]] Result<proto::RunSummary, SimFailure> run_simulation(const SimConfig& config,
                                                                   const SimObservers& observers = {});

}  // namespace rejuv::flight
