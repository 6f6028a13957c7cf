#include "rejuv/flight/sr_sim.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <utility>

#include "rejuv/flight/attack.hpp"
#include "rejuv/flight/detail/printf.hpp"
#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight/output_driver.hpp"
#include "rejuv/flight/sr_kernel_model.hpp"

namespace rejuv::flight {

std::string SimFailure::to_string() const {
  switch (kind) {
    case SimError::Design: return "control design: " + message;
    case SimError::Config: return "configuration: " + message;
    case SimError::Diverged: return "simulation diverged: " + message;
  }
  return message;
}

namespace {

using WallClock = std::chrono::steady_clock;

// The rejuvenated software: everything a checkpoint saves and a rollback restores (§V: "the whole program").
// The controllers are stateless (their gains are read-only data, like the code), so the image holds the
// estimator, the setpoint generator and the rollback handler of checkpoint_p.
struct SoftwareImage {
  EstimatorNode estimator;
  SetpointGenerator setpoints;
  RollbackHandler handler;
};

// Samples published while the software is stopped for a checkpoint wait in the broker's queues (uORB-like,
// bounded: the oldest is dropped when full) and are delivered when it resumes.
class SampleQueue {
 public:
  void push(const plant::SensorSamples& s) {
    if (size_ == ring_.size()) {
      head_ = (head_ + 1) % ring_.size();
      --size_;
    }
    ring_[(head_ + size_) % ring_.size()] = s;
    ++size_;
  }
  template <class F>
  void drain(F&& f) {
    while (size_ > 0) {
      f(ring_[head_]);
      head_ = (head_ + 1) % ring_.size();
      --size_;
    }
  }
  void clear() { head_ = size_ = 0; }

 private:
  std::array<plant::SensorSamples, 16> ring_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

bool any(const plant::SensorSamples& s) { return s.gyro || s.accel || s.mag || s.baro || s.gps; }

StateVec true_state(const plant::QuadState& q) {
  return make_state(q.p_NB_N, q.v_NB_N, euler_from_quaternion(q.q_NB), q.omega_B_rad_s);
}

}  // namespace

struct SrSimulation::Impl {
  enum class Freeze : std::uint8_t { None, Rollback, Checkpoint };

  SimConfig cfg;
  ControlDesign design;
  std::shared_ptr<const WaypointPath> path;
  plant::Quadrotor plant;
  plant::SensorSuite sensors;
  plant::Wind wind;
  OutputDriver driver;
  SoftwareImage sw;
  ImageStore<SoftwareImage> images;
  RejuvenationTimer timer;
  Epoch epoch{0};
  SrMode mode = SrMode::SC;
  Freeze freeze = Freeze::None;
  Nanos freeze_until{0};
  SampleQueue cp_queue;
  // Estimate catch-up (SimConfig::estimate_catch_up): the plant's sensor samples since the latest checkpoint's
  // cut, kept outside the software (the kernel's log in the runtime), and whether the last is this step's.
  std::vector<plant::SensorSamples> since_checkpoint;
  bool logged_this_step = false;

  Nanos t{0};
  Nanos dt;
  Nanos control_period;
  Nanos next_sample{0};
  Nanos next_progress{0};
  // Tracker without SR (same update rule, §VI-D Table I).
  Nanos next_check{0};
  Nanos hold_until{0};
  // Attack state of the compromised service (wiped by every rollback): whether the current MC window is attacked,
  // since when (τ of the attack library's laws), and the attack's constants.
  bool attacking = false;
  Nanos window_began{0};
  double magnitude = 0.0;
  StateVec fdi_dir = StateVec::Zero();
  LqrController overwritten_mission;  // GAIN_OVERWRITE: the mission controller with the attacker's gain
  // The setpoint as last published on the topic (what the run recorder computes V against in the runtime): the
  // generator's, or SETPOINT_SHIFT's while the attacker publishes; a rollback does not unpublish it, the
  // generator's next move does.
  std::optional<StateVec> attacker_setpoint;
  bool calm = false;

  // Metrics.
  std::uint64_t rollbacks = 0, checkpoints = 0, attack_windows = 0;
  double d_sum_m = 0, d_max_m = 0;
  std::uint64_t d_count = 0;
  double max_V = 0, max_est_err_P = 0;
  bool completed = false, lost = false, done = false, stopped_after_attacks = false;
  Nanos completed_at{0};
  WallClock::time_point wall_start = WallClock::now();
  // The observers of the step in progress (nullptr outside step()); SR events before the first step (the
  // boot cycle's) wait in `early_events`.
  const SimObservers* active_obs = nullptr;
  std::vector<SrEvent> early_events;

  Impl(SimConfig config, ControlDesign d, std::shared_ptr<const WaypointPath> p, const plant::QuadState& initial,
       const EkfState& ekf_initial)
      : cfg(std::move(config)),
        design(std::move(d)),
        path(std::move(p)),
        plant(cfg.quad, initial),
        sensors(cfg.sensors, cfg.seed),
        wind(cfg.wind, cfg.seed ^ 0x9e3779b97f4a7c15ULL),
        driver(plant.mixer().inverse(), design.full, design.restricted, design.u_hover),
        sw{EstimatorNode(cfg.ekf, ekf_initial, cfg.sensors.gyro_period), SetpointGenerator(path),
           RollbackHandler(cfg.handler)},
        images(cfg.keep_generations),
        dt(to_nanos(cfg.physics_step)),
        control_period(cfg.sensors.gyro_period),
        magnitude(effective_magnitude(cfg.attack.law, cfg.attack.magnitude)),
        fdi_dir(fdi_direction(design)),
        overwritten_mission(design.mission.with_gain(overwritten_gain(design.mission.K(), magnitude))),
        calm(cfg.wind.gust_std_m_s == 0.0) {}

  [[nodiscard]] bool sr_on() const { return cfg.sr == SrSwitch::On; }

  [[nodiscard]] Nanos wall_now() const { return std::chrono::duration_cast<Nanos>(WallClock::now() - wall_start); }

  // The model's SrEvent (sr_event.hpp), as the runtime's kernel reports it; the handler is the only requester.
  void event(SrEventKind kind, Nanos now, Generation g = {}, Nanos span = {}) {
    const SrEvent e{.kind = kind, .t = now, .wall = wall_now(), .epoch = epoch, .g = g, .mode = mode, .span = span,
                    .by = std::nullopt};
    if (active_obs == nullptr) {
      early_events.push_back(e);
    } else if (active_obs->sr_event) {
      active_obs->sr_event(e);
    }
  }

  void begin_handler_run(Nanos now) {
    event(SrEventKind::HandlerRun, now);
    handle(sw.handler.on_rollback_signal(now), now);
  }

  // The same sensors, at the same hover, for `alignment` before t = 0 (the plant is at rest there: a = 0).
  void align(const plant::QuadState& hover) {
    const Nanos start = -to_nanos(cfg.alignment);
    for (Nanos t_align = start; t_align < Nanos{0}; t_align += dt) {
      (void)sw.estimator.on_samples(sensors.step(t_align, hover, Eigen::Vector3d::Zero()));
    }
  }

  [[nodiscard]] bool attacking_with(AttackLaw law) const { return attacking && cfg.attack.law == law; }
  [[nodiscard]] Seconds tau() const { return to_seconds(t - window_began); }

  // x̂ as ekf2 publishes it: the filter's, shifted by a compromised ekf2 (ESTIMATE_SHIFT, ESTIMATE_DRIFT).
  [[nodiscard]] StateVec published_estimate() const {
    const StateVec& x_hat = sw.estimator.estimate();
    if (!attacking_with(AttackLaw::EstimateShift) && !attacking_with(AttackLaw::EstimateDrift)) return x_hat;
    return x_hat + estimate_offset(cfg.attack.law, fdi_dir, magnitude, tau());
  }
  // x_sp as lqr_control holds it in MC: the generator's, or the one a compromised gen_set_point publishes.
  [[nodiscard]] StateVec mission_setpoint() const {
    if (!attacking_with(AttackLaw::SetpointShift)) return sw.setpoints.setpoint();
    return sw.setpoints.setpoint() + setpoint_offset(magnitude, tau());
  }
  [[nodiscard]] StateVec published_setpoint() const { return attacker_setpoint.value_or(sw.setpoints.setpoint()); }

  [[nodiscard]] double V_hat() const { return design.ellipsoid.V(published_estimate(), sw.setpoints.setpoint()); }

  void begin_attack(Nanos now) {
    attacking = true;
    window_began = now;
    ++attack_windows;
  }

  void begin_mc_window(Nanos now) {
    const AttackConfig& a = cfg.attack;
    if (a.enabled == AttackSwitch::On && now >= to_nanos(a.start) &&
        (a.max_windows == 0 || attack_windows < a.max_windows)) {
      begin_attack(now);
    }
  }

  // The generator moved x_sp: it publishes it, replacing whatever the attacker published last.
  void setpoint_moved(UpdateOutcome outcome) {
    if (outcome == UpdateOutcome::Moved) attacker_setpoint.reset();
  }

  void handle(HandlerRequest request, Nanos now) {
    switch (request) {
      case HandlerRequest::None: return;
      case HandlerRequest::EnterSafetyControl:
        mode = SrMode::SC;
        driver.set_limits(LimitSet::Full);
        attacking = false;
        event(SrEventKind::Mode, now);
        return;
      case HandlerRequest::UpdateSetpoint:
        mode = SrMode::Update;
        event(SrEventKind::Mode, now);
        setpoint_moved(sw.setpoints.update(published_estimate(), design.ellipsoid, cfg.rho_M));
        return;
      case HandlerRequest::Checkpoint: {
        // The image is the software as it is now, its handler inside checkpoint(): restored later, that call
        // returns Restored (docs/design.md §7). The software then stops for T_CP; controls from SC are held (§II).
        mode = SrMode::CP;
        event(SrEventKind::Mode, now);
        const Generation g = images.save(sw, now);
        since_checkpoint.clear();  // the replay of a rollback to this image starts at its cut
        ++checkpoints;
        // At the start of the stop, as the kernel's comes before the step's charge (figure_data.hpp).
        event(SrEventKind::Checkpoint, now, g, to_nanos(cfg.t_cp));
        freeze = Freeze::Checkpoint;
        freeze_until = now + to_nanos(cfg.t_cp);
        return;
      }
      case HandlerRequest::ArmTimerAndEnterMission:
        // A refusal is impossible in a correct run (one Taken per epoch); the count is reported for comparison.
        event(timer.arm(epoch, now, to_nanos(cfg.t_mc)) ? SrEventKind::TimerArmed : SrEventKind::TimerRefused, now,
              {}, to_nanos(cfg.t_mc));
        driver.set_limits(LimitSet::Restricted);
        event(SrEventKind::LimitsWritten, now);
        mode = SrMode::MC;
        event(SrEventKind::Mode, now);
        if (cfg.stop_after_attacks > 0 && attack_windows >= cfg.stop_after_attacks) {
          stopped_after_attacks = true;  // the last attacked window and its secure interval are flown
          done = true;
          return;
        }
        begin_mc_window(now);
        return;
    }
  }

  // The mission controller's step in MC, as the compromised service of the attack (if any) makes it.
  [[nodiscard]] InputVec mission_control(const StateVec& x_hat, const StateVec& x_sp) const {
    if (attacking_with(AttackLaw::WorstCaseControl)) {
      return worst_case_corner(design.restricted, design.ellipsoid.P(), design.continuous.B, state_error(x_hat, x_sp));
    }
    if (attacking_with(AttackLaw::GainOverwrite)) return overwritten_mission.control(x_hat, x_sp);
    return design.mission.control(x_hat, x_sp);
  }

  void control_step(Nanos now) {
    const StateVec x_hat = published_estimate();
    InputVec u = design.u_hover;
    switch (mode) {
      case SrMode::MC: {
        if (!sr_on() && !attacking && cfg.attack.enabled == AttackSwitch::On && now >= to_nanos(cfg.attack.start) &&
            attack_windows == 0) {
          begin_attack(now);  // without SR the one MC window never ends: the attack starts once and stays
        }
        const StateVec x_sp = mission_setpoint();
        if (attacking_with(AttackLaw::SetpointShift)) attacker_setpoint = x_sp;
        u = mission_control(x_hat, x_sp);
        break;
      }
      case SrMode::SC:
      case SrMode::Update:
        u = design.safety.control(x_hat, sw.setpoints.setpoint());
        break;
      case SrMode::RB:
      case SrMode::CP:
        return;  // the software is stopped: the output driver holds the last controls
    }
    driver.publish(now, u);
    if (active_obs != nullptr && active_obs->control_update) active_obs->control_update(now, wall_now());
  }

  void track_without_sr(Nanos now) {
    if (now < next_check) return;
    next_check += to_nanos(cfg.handler.check_period);
    if (now < hold_until) return;
    const double rho_s = cfg.handler.rho_s;
    if (V_hat() < rho_s * rho_s) {
      const UpdateOutcome outcome = sw.setpoints.update(published_estimate(), design.ellipsoid, cfg.rho_M);
      setpoint_moved(outcome);
      if (outcome == UpdateOutcome::Moved) hold_until = now + to_nanos(cfg.handler.t_min);
    }
  }

  void check_completion(Nanos now) {
    if (completed || !sw.setpoints.finished()) return;
    const Eigen::Vector3d goal = path->waypoints().back().p_N_m;
    if ((published_estimate().segment<3>(idx::kPos) - goal).norm() <= cfg.acceptance_radius_m) {
      completed = true;
      completed_at = now;
    }
  }

  void run_software(Nanos now, const plant::SensorSamples& raw) {
    plant::SensorSamples samples = raw;
    // A compromised sensors service biases the combined IMU data ekf2 integrates (SENSOR_BIAS).
    if (attacking_with(AttackLaw::SensorBias) && samples.gyro) samples.gyro->omega_B_rad_s += gyro_bias(magnitude);
    const bool fresh = sw.estimator.on_samples(samples);
    if (fresh) {
      const StateVec x = true_state(plant.state());
      max_est_err_P = std::max(max_est_err_P, design.ellipsoid.V(x, published_estimate()));
      control_step(now);
    }
    if (sr_on()) {
      handle(sw.handler.tick(now, [this] { return V_hat(); }), now);
    } else {
      track_without_sr(now);
    }
    if (fresh) check_completion(now);
  }

  void start_rollback(Nanos now) {
    // RB: network off, the software is killed; the controls stay at their last (possibly malicious) value.
    mode = SrMode::RB;
    freeze = Freeze::Rollback;
    freeze_until = now + to_nanos(cfg.t_rb);
    if (cfg.estimate_catch_up) {
      // The replay is part of the stop, charged by the samples logged so far (those of the stop are a few more).
      freeze_until += static_cast<std::int64_t>(since_checkpoint.size()) * cfg.catch_up_charge_per_sample;
    }
    ++rollbacks;
    event(SrEventKind::Mode, now);
    // At the start of the stop, with the generation it restores and the epoch it opens (figure_data.hpp).
    if (const auto* entry = images.latest(); entry != nullptr) {
      const Epoch current = epoch;
      epoch = Epoch{epoch.value() + 1};
      event(SrEventKind::Rollback, now, entry->generation, to_nanos(cfg.t_rb));
      epoch = current;
    }
  }

  void finish_rollback(Nanos now) {
    const auto* entry = images.latest();
    REJUV_ASSERT(entry != nullptr, "rollback without a checkpoint");
    sw = entry->image;  // estimator, setpoint generator and handler as they were at the checkpoint
    epoch = Epoch{epoch.value() + 1};
    freeze = Freeze::None;
    attacking = false;  // the corruption is wiped with the rest of the image
    cp_queue.clear();   // the broker's queues go back to the cut too
    handle(sw.handler.on_checkpoint_return(CheckpointRestored{entry->generation, epoch}), now);
    if (cfg.estimate_catch_up) {
      // The restored (clean) estimator is fed what the plant's sensors delivered since its checkpoint, in order:
      // trusted input only, never what a (possibly compromised) service published. x̂ ends as fresh as a
      // never-attacked estimator's, so its covariance is not re-armed.
      // The step's own samples (logged last) are the software's to handle after this.
      const std::size_t n = since_checkpoint.size() - (logged_this_step ? 1 : 0);
      for (std::size_t i = 0; i < n; ++i) (void)sw.estimator.on_samples(since_checkpoint[i]);
      since_checkpoint.clear();
      logged_this_step = false;
    } else {
      // RollbackSignal to the services that asked for it (docs/design.md §7 step 3): ekf2 and checkpoint_p.
      sw.estimator.on_rollback(cfg.ekf_rearm);
    }
    begin_handler_run(now);
  }

  void finish_checkpoint(Nanos now) {
    freeze = Freeze::None;
    const auto* entry = images.latest();
    REJUV_ASSERT(entry != nullptr, "checkpoint finished without an image");
    handle(sw.handler.on_checkpoint_return(CheckpointTaken{entry->generation}), now);
    bool fresh = false;
    cp_queue.drain([&](const plant::SensorSamples& s) { fresh = sw.estimator.on_samples(s) || fresh; });
    if (fresh) control_step(now);
  }

  // Metrics and the trace are sampled once per control period (250 Hz): V and d move by well under 1 % in 4 ms,
  // and sampling every physics step would cost a tenth of the run time in Euler angles and distances.
  void record(Nanos now, const SimObservers& observers) {
    if (observers.progress && now >= next_progress) {
      next_progress += to_nanos(observers.progress_every);
      report_progress(observers, Report::Periodic);
    }
    if (now < next_sample) return;
    next_sample += control_period;
    const plant::QuadState& q = plant.state();
    const StateVec x = true_state(q);
    const double V = design.ellipsoid.V(x, published_setpoint());
    if (!std::isfinite(V) || !x.allFinite()) {
      lost = true;
      done = true;
      return;
    }
    max_V = std::max(max_V, V);
    const double d = path->distance_to(q.p_NB_N);
    d_sum_m += d;
    d_max_m = std::max(d_max_m, d);
    ++d_count;
    if (V > cfg.lost_V) {
      lost = true;
      done = true;
    }
    if (observers.trace) {
      observers.trace(TraceRow{.t = now, .x = x, .x_hat = published_estimate(), .x_sp = published_setpoint(),
                               .mode = mode, .u = driver.applied_u(), .V = V,
                               .est_err = design.ellipsoid.V(x, published_estimate())});
    }
  }

  enum class Report : std::uint8_t { Periodic, Final };

  void report_progress(const SimObservers& observers, Report kind) const {
    const PathCursor& c = sw.setpoints.cursor();
    const double segments = static_cast<double>(path->segment_count());
    observers.progress(ProgressReport{.sim_time = to_seconds(t),
                                      .wall_time = std::chrono::duration<double>(WallClock::now() - wall_start),
                                      .mode = mode,
                                      .path_progress = segments > 0 ? c.progress() / segments : 1.0,
                                      .rollbacks = rollbacks,
                                      .max_V = max_V,
                                      .final = kind == Report::Final});
  }

  bool step(const SimObservers& obs) {
    if (done) return false;
    active_obs = &obs;
    if (!early_events.empty()) {
      if (obs.sr_event) {
        for (const SrEvent& e : early_events) obs.sr_event(e);
      }
      early_events.clear();
    }
    const bool going_on = step_once(obs);
    active_obs = nullptr;
    return going_on;
  }

  bool step_once(const SimObservers& observers) {
    const Nanos now = t;
    const plant::SensorSamples samples = sensors.step(now, plant.state(), plant.acceleration_N());
    logged_this_step = cfg.estimate_catch_up && sr_on() && any(samples);
    if (logged_this_step) since_checkpoint.push_back(samples);
    if (freeze == Freeze::Rollback && now >= freeze_until) finish_rollback(now);
    if (freeze == Freeze::Checkpoint && now >= freeze_until) finish_checkpoint(now);
    if (sr_on() && freeze == Freeze::None && timer.fire_if_due(now)) start_rollback(now);
    switch (freeze) {
      case Freeze::None: run_software(now, samples); break;
      case Freeze::Checkpoint:
        if (any(samples)) cp_queue.push(samples);
        break;
      case Freeze::Rollback: break;  // published after the cut: discarded with the restored queues
    }
    record(now, observers);
    if (completed || t >= to_nanos(cfg.timeout)) done = true;
    // A calm day needs no gust process (and its random draws are a tenth of the run time).
    const Eigen::Vector3d wind_N_m_s = calm ? cfg.wind.mean_N_m_s : wind.step(cfg.physics_step);
    plant.step(cfg.physics_step, driver.motor_command(), wind_N_m_s);
    t += dt;
    if (done && observers.progress) report_progress(observers, Report::Final);
    return !done;
  }

  [[nodiscard]] proto::RunSummary summary() const {
    proto::RunSummary s;
    s.set_graph(cfg.graph_name);
    s.set_runner("sim");
    s.set_sr(sr_on());
    s.set_attack(cfg.attack.enabled == AttackSwitch::On);
    if (cfg.attack.enabled == AttackSwitch::On) s.set_attack_kind(std::string(to_string(cfg.attack.law)));
    s.set_seed(cfg.seed);
    s.set_mission_completed(completed);
    s.set_mission_time_s(to_seconds(completed ? completed_at : t).count());
    s.set_d_mean_m(d_count > 0 ? d_sum_m / static_cast<double>(d_count) : 0.0);
    s.set_d_max_m(d_max_m);
    s.set_max_v(max_V);
    s.set_max_est_err_p(max_est_err_P);
    s.set_left_safety_set(max_V >= 1.0);
    s.set_rollbacks(rollbacks);
    s.set_checkpoints(checkpoints);
    s.set_attacks(attack_windows);
    s.set_stopped_after_attacks(stopped_after_attacks);
    s.set_max_control_gap_ms(std::chrono::duration<double, std::milli>(driver.max_gap()).count());
    // What the model charges a checkpoint and a rollback (T_CP, T_RB), as `rejuv run` reports its lockstep's.
    s.mutable_charging()->set_charge("model");
    s.mutable_charging()->set_checkpoint_charge_ms(cfg.t_cp.count() * 1e3);
    s.mutable_charging()->set_rollback_charge_ms(cfg.t_rb.count() * 1e3);
    const double wall_s = std::chrono::duration<double>(WallClock::now() - wall_start).count();
    const double sim_s = to_seconds(t).count();
    s.set_sim_time_s(sim_s);
    s.set_wall_time_s(wall_s);
    s.set_realtime_factor(wall_s > 0.0 ? sim_s / wall_s : 0.0);
    return s;
  }
};

Result<SrSimulation, SimFailure> SrSimulation::create(const SimConfig& config) {
  SimConfig cfg = config;
  if (!(cfg.physics_step.count() > 0.0) || !(cfg.timeout.count() > 0.0) || !(cfg.t_mc.count() > 0.0) ||
      cfg.t_rb.count() < 0.0 || cfg.t_cp.count() < 0.0 || !(cfg.handler.check_period.count() > 0.0)) {
    return fail(SimFailure{SimError::Config, "physics step, timeout, T_MC and check period must be > 0; T_RB, T_CP >= 0"});
  }
  if (auto v = cfg.sensors.validate(); !v) return fail(SimFailure{SimError::Config, "sensors: " + v.error()});
  cfg.control = control_spec_for(cfg);
  cfg.ekf.gps_delay = to_seconds(cfg.sensors.gps_delay);
  cfg.ekf.gravity_m_s2 = cfg.quad.gravity_m_s2;
  cfg.ekf.drag_over_mass_per_s = cfg.quad.drag_coefficient_N_s_m / cfg.quad.mass_kg;
  auto design = design_control(cfg.control);
  if (!design) return fail(SimFailure{SimError::Design, design.error().to_string()});
  auto path = WaypointPath::make(cfg.waypoints);
  if (!path) return fail(SimFailure{SimError::Config, "mission: " + path.error().message});
  // The mission starts hovering at the first waypoint (§IV-B), heading as that waypoint says.
  const PathWaypoint& first = cfg.waypoints.front();
  plant::QuadState initial = plant::Quadrotor::hover_at(cfg.quad, first.p_N_m);
  initial.q_NB = Eigen::Quaterniond(Eigen::AngleAxisd(first.yaw_rad, Eigen::Vector3d::UnitZ()));
  const EkfState ekf_initial{.p_N_m = initial.p_NB_N, .v_N_m_s = initial.v_NB_N, .q_NB = initial.q_NB};
  auto impl = std::make_unique<Impl>(std::move(cfg), std::move(*design),
                                     std::make_shared<const WaypointPath>(std::move(*path)), initial, ekf_initial);
  impl->align(initial);
  if (impl->sr_on()) {
    // Boot: the first cycle is a rollback-handler run without a rollback (SC, T_est, (1), update, CP, MC).
    impl->begin_handler_run(Nanos{0});
  } else {
    impl->mode = SrMode::MC;
    impl->driver.set_limits(LimitSet::Restricted);
  }
  return SrSimulation(std::move(impl));
}

SrSimulation::SrSimulation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SrSimulation::SrSimulation(SrSimulation&&) noexcept = default;
SrSimulation& SrSimulation::operator=(SrSimulation&&) noexcept = default;
SrSimulation::~SrSimulation() = default;

bool SrSimulation::step(const SimObservers& observers) { return impl_->step(observers); }
bool SrSimulation::finished() const { return impl_->done; }
Nanos SrSimulation::now() const { return impl_->t; }
SrMode SrSimulation::mode() const { return impl_->mode; }
const StateVec& SrSimulation::estimate() const { return impl_->sw.estimator.estimate(); }
StateVec SrSimulation::published_estimate() const { return impl_->published_estimate(); }
const StateVec& SrSimulation::setpoint() const { return impl_->sw.setpoints.setpoint(); }
StateVec SrSimulation::truth() const { return true_state(impl_->plant.state()); }
const ControlDesign& SrSimulation::design() const { return impl_->design; }
proto::RunSummary SrSimulation::summary() const { return impl_->summary(); }

Result<proto::RunSummary, SimFailure> run_simulation(const SimConfig& config, const SimObservers& observers) {
  auto sim = SrSimulation::create(config);
  if (!sim) return fail(sim.error());
  while (sim->step(observers)) {
  }
  return sim->summary();
}

}  // namespace rejuv::flight
