#include "run_recorder.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "rejuv/flight/attack.hpp"
#include "rejuv/flight_io/messages.hpp"
#include "payload.hpp"
#include "report.hpp"

namespace rejuv::cli {
namespace {

// The forged controls are the corner itself (worst_case_corner returns the box's bounds); an honest LQR
// output clamped to Ū lands on all four bounds of that very corner only by coincidence.
bool same_controls(const flight::InputVec& a, const flight::InputVec& b) {
  for (Eigen::Index j = 0; j < a.size(); ++j) {
    if (std::abs(a[j] - b[j]) > 1e-9 * (1.0 + std::abs(b[j]))) return false;
  }
  return true;
}

bool attacked(std::uint64_t samples, std::uint64_t corners) { return samples > 0 && 2 * corners > samples; }

}  // namespace

Result<RunReference, std::string> run_reference(const launch::LoadedLaunch& graph,
                                                std::optional<std::uint64_t> seed) {
  flight::SimOverrides overrides;
  overrides.sr = flight::SrSwitch::Off;
  if (seed) overrides.seed = *seed;
  auto config = flight::config_from_launch(graph, overrides);
  if (!config) return fail(config.error().to_string());
  auto design = flight::design_control(config->control);
  if (!design) return fail("rejuv run: control design: " + design.error().to_string());
  auto path = flight::WaypointPath::make(config->waypoints);
  if (!path) return fail("rejuv run: mission path: " + path.error().message);
  std::optional<flight::AttackConfig> library;
  if (config->attack.enabled == flight::AttackSwitch::On && config->attack.law != flight::AttackLaw::WorstCaseControl) {
    library = config->attack;
  }
  return RunReference{.design = std::move(*design),
                      .path = std::move(*path),
                      .alignment = std::chrono::round<Nanos>(config->alignment),
                      .lost_V = config->lost_V,
                      .library_attack = library};
}

RunRecorder::RunRecorder(RunReference reference, std::FILE* csv, Progress progress)
    : ref_(std::move(reference)), csv_(csv), progress_(progress) {
  if (csv_ != nullptr) write_trace_header(csv_);
}

void RunRecorder::on_publication(const kernel::Publication& p) {
  if (carries<rejuv_msg_GroundTruth>(p)) {
    on_truth(payload_as<rejuv_msg_GroundTruth>(p.payload), p.t);
  } else if (carries<rejuv_msg_VehicleStateEstimate>(p)) {
    const auto m = payload_as<rejuv_msg_VehicleStateEstimate>(p.payload);
    if (auto x = flight_io::state_from_message(m)) {
      x_hat_ = *x;
      x_hat_stamp_ = Nanos{static_cast<std::int64_t>(m.timestamp_ns)};
    }
  } else if (carries<rejuv_msg_Setpoint>(p)) {
    const auto m = payload_as<rejuv_msg_Setpoint>(p.payload);
    if (auto x = flight_io::setpoint_from_message(m)) x_sp_ = *x;
    if (m.mission_done == 1 && !completed_at_) completed_at_ = std::max(p.t - ref_.alignment, Nanos{0});
  } else if (carries<rejuv_msg_ActuatorControls>(p)) {
    const auto m = payload_as<rejuv_msg_ActuatorControls>(p.payload);
    if (auto u = flight_io::controls_from_message(m)) {
      u_ = *u;
      // In MC only the mission controller holds the right to publish controls (the policy, docs/design.md §8).
      if (mode_ == SrMode::MC) on_mc_controls(*u, Nanos{static_cast<std::int64_t>(m.timestamp_ns)}, m.epoch);
    }
  } else if (carries<rejuv_msg_ActuatorOutputs>(p)) {
    const Nanos stamp{static_cast<std::int64_t>(payload_as<rejuv_msg_ActuatorOutputs>(p.payload).timestamp_ns)};
    if (stamp < ref_.alignment) return;  // aligning: the plant does not apply them
    if (last_output_ && stamp > *last_output_) max_gap_ = std::max(max_gap_, stamp - *last_output_);
    last_output_ = stamp;
  } else if (carries<rejuv_msg_SecurityEvent>(p)) {
    if (attack_ledger_) attack_ledger_->on_security_event(payload_as<rejuv_msg_SecurityEvent>(p.payload));
  } else if (carries<rejuv_msg_SrMode>(p)) {
    const auto m = payload_as<rejuv_msg_SrMode>(p.payload);
    if (auto mode = flight_io::mode_from_message(m)) {
      mode_ = *mode;
      if (attack_ledger_) attack_ledger_->on_mode(*mode, Epoch{m.epoch});
      if (mode_ == SrMode::MC && last_mc_epoch_ != m.epoch) {
        last_mc_epoch_ = m.epoch;
        ++mc_windows_;
      }
    }
  }
}

void RunRecorder::on_control_update(Nanos t, Nanos wall) {
  if (t < ref_.alignment) return;
  if (files_ != nullptr) files_->control_update(t - ref_.alignment, wall);
  if (const auto i = intervals_.add(t - ref_.alignment, wall)) {
    // Kernel time: simulated in lockstep, the monotonic clock in real time.
    const double ms = std::chrono::duration<double, std::milli>(i->dt).count();
    if (i->mark == IntervalMark::Checkpoint) at_cp_ms_.add(ms);
    if (i->mark == IntervalMark::Rollback) at_rb_ms_.add(ms);
  }
}

void RunRecorder::on_sr_event(const SrEvent& event) {
  SrEvent e = event;
  e.t -= ref_.alignment;
  intervals_.on_event(e);
  if (files_ != nullptr) files_->sr_event(e);
}

void RunRecorder::on_step(std::uint64_t /*step*/, Nanos t, SrMode mode) {
  mode_ = mode;
  if (attack_ledger_) attack_ledger_->on_step(t, mode);
  if (progress_ == Progress::Off) return;
  const Nanos every = progress_ == Progress::Every1s ? std::chrono::seconds{1} : std::chrono::seconds{10};
  if (t - last_progress_ < every) return;
  last_progress_ = t;
  const flight::StateVec& x = x_;
  std::fprintf(stderr, "rejuv run: t = %6.1f s  mode %s  position (%.2f, %.2f, %.2f) m  d_max %.1f cm  max V %.3f\n",
               to_seconds(t).count(), mode_name(mode_), x[0], x[1], x[2], 100.0 * d_max_, max_V_);
}

void RunRecorder::fill(proto::RunSummary& s, Nanos end) const {
  s.set_mission_completed(completed_at_.has_value());
  s.set_mission_time_s(to_seconds(completed_at_.value_or(std::max(end - ref_.alignment, Nanos{0}))).count());
  s.set_d_mean_m(d_count_ > 0 ? d_sum_ / static_cast<double>(d_count_) : 0.0);
  s.set_d_max_m(d_max_);
  s.set_max_v(max_V_);
  s.set_max_est_err_p(max_est_err_);
  s.set_left_safety_set(max_V_ >= 1.0 || lost_.has_value());
  s.set_max_control_gap_ms(std::chrono::duration<double, std::milli>(max_gap_).count());
  fill_percentiles(*s.mutable_control_interval_at_cp_ms(), at_cp_ms_);
  fill_percentiles(*s.mutable_control_interval_at_rb_ms(), at_rb_ms_);
  s.set_attacks(stopped_after_attacks_ ? attacked_closed_ : attacked_windows());
  s.set_stopped_after_attacks(stopped_after_attacks_);
  if (attack_ledger_) attack_ledger_->fill(s);
}

bool RunRecorder::window_attacked(const Window& w) const {
  return ref_.library_attack ? w.planned : attacked(w.samples, w.corners);
}

std::uint64_t RunRecorder::attacked_windows() const {
  return attacked_closed_ + (window_ && window_attacked(*window_) ? 1 : 0);
}

void RunRecorder::on_mc_controls(const flight::InputVec& u, Nanos stamp, std::uint32_t epoch) {
  if (stamp < ref_.alignment || !x_hat_ || !x_sp_) return;
  // Only controls computed from the estimate the recorder holds (the controller stamps them with it).
  if (stamp != x_hat_stamp_) return;
  if (!window_ || window_->epoch != epoch) {
    if (window_ && window_attacked(*window_)) ++attacked_closed_;
    window_ = Window{.epoch = epoch};
    if (const auto& plan = ref_.library_attack;
        plan && stamp - ref_.alignment >= std::chrono::round<Nanos>(plan->start) &&
        (plan->max_windows == 0 || planned_windows_ < plan->max_windows)) {
      window_->planned = true;
      ++planned_windows_;
    }
    if (stop_after_ > 0 && attacked_closed_ >= stop_after_ && !stopped_after_attacks_) {
      stopped_after_attacks_ = true;
      std::fprintf(stderr, "rejuv run: %llu attacked MC windows flown: stopping the run (stop_after_attacks)\n",
                   static_cast<unsigned long long>(attacked_closed_));
      if (stop_attacks_) stop_attacks_();
    }
  }
  ++window_->samples;
  const flight::InputVec corner = flight::worst_case_corner(ref_.design.restricted, ref_.design.ellipsoid.P(),
                                                            ref_.design.continuous.B,
                                                            flight::state_error(*x_hat_, *x_sp_));
  if (same_controls(u, corner)) ++window_->corners;
}

void RunRecorder::declare_lost(Nanos t, double V) {
  if (lost_) return;
  lost_ = VehicleLost{.t = t - ref_.alignment, .V = V};
  std::fprintf(stderr, "rejuv run: vehicle lost at t = %.1f s: V = %.4g > %g: stopping the run\n",
               to_seconds(lost_->t).count(), V, ref_.lost_V);
  if (stop_) stop_();
}

void RunRecorder::on_truth(const rejuv_msg_GroundTruth& g, Nanos t) {
  const Eigen::Vector3d p(g.p_N_m[0], g.p_N_m[1], g.p_N_m[2]);
  const Eigen::Quaterniond q(g.q_NB[0], g.q_NB[1], g.q_NB[2], g.q_NB[3]);
  x_ = flight::make_state(p, Eigen::Vector3d(g.v_N_m_s[0], g.v_N_m_s[1], g.v_N_m_s[2]),
                          flight::euler_from_quaternion(q.normalized()),
                          Eigen::Vector3d(g.omega_B_rad_s[0], g.omega_B_rad_s[1], g.omega_B_rad_s[2]));
  if (t < ref_.alignment) return;  // aligning: at rest, not flying yet
  if (!x_.allFinite()) {
    declare_lost(t, std::numeric_limits<double>::infinity());
    return;
  }
  const double d = ref_.path.distance_to(p);
  d_sum_ += d;
  d_max_ = std::max(d_max_, d);
  ++d_count_;
  double V = 0;
  if (x_sp_) {
    V = ref_.design.ellipsoid.V(x_, *x_sp_);
    if (std::isfinite(V)) max_V_ = std::max(max_V_, V);
    if (attack_ledger_) attack_ledger_->on_V(V);
    if (!std::isfinite(V) || V > ref_.lost_V) declare_lost(t, V);
  }
  const double est_err = x_hat_ ? ref_.design.ellipsoid.V(x_, *x_hat_) : 0.0;
  max_est_err_ = std::max(max_est_err_, est_err);
  if (csv_ != nullptr || files_ != nullptr) {
    const flight::TraceRow row{.t = t - ref_.alignment,
                               .x = x_,
                               .x_hat = x_hat_.value_or(flight::StateVec::Zero()),
                               .x_sp = x_sp_.value_or(flight::StateVec::Zero()),
                               .mode = mode_,
                               .u = u_,
                               .V = V,
                               .est_err = est_err};
    if (csv_ != nullptr) write_trace_row(csv_, row);
    if (files_ != nullptr) files_->trace(row);
  }
}

}  // namespace rejuv::cli
