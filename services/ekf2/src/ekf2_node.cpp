#include "rejuv/services/ekf2/ekf2_node.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

namespace rejuv::services {

Ekf2Node::Ekf2Node(const flight::EkfParams& params, const flight::EkfState& initial, Nanos imu_period)
    : params_(params), imu_period_(imu_period), node_(std::in_place, params, initial, imu_period) {}

Ekf2Node::Ekf2Node(const flight::EkfParams& params, const Eigen::Quaterniond& attitude, Nanos imu_period)
    : params_(params), imu_period_(imu_period), waiting_attitude_(attitude) {}

Ekf2Node Ekf2Node::from_first_fix(const flight::EkfParams& params, const Eigen::Quaterniond& attitude,
                                  Nanos imu_period) {
  return Ekf2Node(params, attitude, imu_period);
}

void Ekf2Node::flush_held() {
  if (node_) (void)node_->on_samples(held_);  // no gyro sample: fuses only, x̂ is published with the next tick
  held_ = {};
}

Result<void, flight_io::InputFailure> Ekf2Node::on_mag(const rejuv_msg_SensorMag& message) {
  auto s = flight_io::mag_sample(message);
  if (!s) return fail(std::move(s.error()));
  if (catch_up_ == CatchUp::Replaying || catch_up_ == CatchUp::Replayed) {
    plant::SensorSamples one;
    one.mag = *s;
    on_replayed_aiding(s->t, std::move(one));
    return {};
  }
  if (held_.mag) flush_held();
  held_.mag = *s;
  return {};
}

Result<void, flight_io::InputFailure> Ekf2Node::on_baro(const rejuv_msg_SensorBaro& message) {
  auto s = flight_io::baro_sample(message);
  if (!s) return fail(std::move(s.error()));
  if (catch_up_ == CatchUp::Replaying || catch_up_ == CatchUp::Replayed) {
    plant::SensorSamples one;
    one.baro = *s;
    on_replayed_aiding(s->t, std::move(one));
    return {};
  }
  if (held_.baro) flush_held();
  held_.baro = *s;
  return {};
}

Result<void, flight_io::InputFailure> Ekf2Node::on_gps(const rejuv_msg_SensorGps& message) {
  auto s = flight_io::gps_sample(message);
  if (!s) return fail(std::move(s.error()));
  if (!node_) {
    // The first fix after a cold restart: the filter starts here. The fix is gps_delay old; in the hover the
    // vehicle keeps, its velocity carries it forward well enough (the gates take the rest).
    node_.emplace(params_,
                  flight::EkfState{.p_N_m = s->p_N_m + s->v_N_m_s * params_.gps_delay.count(),
                                   .v_N_m_s = s->v_N_m_s,
                                   .q_NB = waiting_attitude_},
                  imu_period_);
    held_ = {};
    return {};
  }
  if (catch_up_ == CatchUp::Replaying || catch_up_ == CatchUp::Replayed) {
    plant::SensorSamples one;
    one.gps = *s;
    on_replayed_aiding(s->t + std::chrono::round<Nanos>(params_.gps_delay), std::move(one));
    return {};
  }
  if (held_.gps) flush_held();
  held_.gps = *s;
  return {};
}

void Ekf2Node::on_replayed_aiding(Nanos due, plant::SensorSamples sample) {
  const auto at = std::upper_bound(replayed_aiding_.begin(), replayed_aiding_.end(), due,
                                   [](Nanos d, const ReplayedAiding& a) { return d < a.due; });
  replayed_aiding_.insert(at, ReplayedAiding{.due = due, .sample = std::move(sample)});
}

void Ekf2Node::take_replayed_aiding(Nanos t) {
  auto it = replayed_aiding_.begin();
  for (; it != replayed_aiding_.end() && it->due <= t + imu_period_ / 2; ++it) {
    const plant::SensorSamples& one = it->sample;
    if ((one.mag && held_.mag) || (one.baro && held_.baro) || (one.gps && held_.gps)) flush_held();
    if (one.mag) held_.mag = one.mag;
    if (one.baro) held_.baro = one.baro;
    if (one.gps) held_.gps = one.gps;
  }
  replayed_aiding_.erase(replayed_aiding_.begin(), it);
}

void Ekf2Node::finish_replay() {
  // What is left arrived after the replay's last tick (live): held for the next tick, as live samples are.
  take_replayed_aiding(Nanos::max() - imu_period_);
  if (replay_failed_gate()) {
    rearm_now(rearm_, true, true);
    return;
  }
  catch_up_ = CatchUp::Judging;  // the first live GPS sample decides (on_combined)
}

void Ekf2Node::on_rollback(const flight::EkfRearm& rearm) {
  held_ = {};
  if (node_) node_->on_rollback(rearm);
}

void Ekf2Node::on_rollback_signal(const rejuv_msg_RollbackSignal& signal, const flight::EkfRearm& rearm) {
  rearm_ = rearm;
  rearm_.enabled = true;  // a re-arm the catch-up asks for is made whatever sr.ekf_rearm.enabled says
  switch (signal.catch_up) {
    case rejuv_msg_CATCH_UP_OFF:
      catch_up_ = CatchUp::Live;
      replayed_aiding_.clear();
      on_rollback(rearm);
      return;
    case rejuv_msg_CATCH_UP_REPLAY:
      held_ = {};
      replayed_aiding_.clear();
      stale_until_ns_ = 0;
      restored_ = node_;
      gps_rejected_at_restore_ = node_ ? node_->ekf().counters().gps_rejected : 0;
      catch_up_ = node_ ? CatchUp::Replaying : CatchUp::Live;
      return;
    case rejuv_msg_CATCH_UP_DONE:
      if (catch_up_ != CatchUp::Replaying) return;
      // The replay's last ticks may still be on their way through `sensors`: judged once they are integrated.
      replay_end_ns_ = signal.replayed_to_ns;
      catch_up_ = CatchUp::Replayed;
      if (last_tick_ns_ >= replay_end_ns_) finish_replay();
      return;
    case rejuv_msg_CATCH_UP_REARM:
      stale_until_ns_ = signal.replayed_to_ns;
      if (catch_up_ == CatchUp::Live) return;  // not after a REPLAY of this incarnation: nothing to re-arm
      // A replay that could not be judged whole is not trusted in part: the filter as restored, re-armed (§IV);
      // counted as discarded only where what was replayed already failed the gate.
      rearm_now(rearm_, true, replay_failed_gate());
      return;
  }
}

bool Ekf2Node::replay_failed_gate() const {
  return node_ && node_->ekf().counters().gps_rejected != gps_rejected_at_restore_;
}

void Ekf2Node::rearm_now(const flight::EkfRearm& rearm, bool from_restored, bool implausible) {
  if (from_restored && restored_) node_ = restored_;  // the replayed estimate dropped: the filter as restored
  if (implausible) {
    ++discarded_;
    announce_discard_ = true;
  }
  held_ = {};
  replayed_aiding_.clear();
  if (node_) node_->on_rollback(rearm);
  restored_.reset();
  catch_up_ = CatchUp::Live;
}

Result<std::optional<rejuv_msg_VehicleStateEstimate>, flight_io::InputFailure> Ekf2Node::on_combined(
    const rejuv_msg_SensorCombined& message) {
  auto tick = flight_io::imu_tick(message);
  if (!tick) return fail(std::move(tick.error()));
  if (!node_) {
    held_ = {};
    return std::optional<rejuv_msg_VehicleStateEstimate>{};
  }
  // The replay's own ticks that `sensors` publishes after the replay was cut short: late, not live.
  if (message.timestamp_ns <= stale_until_ns_) return std::optional<rejuv_msg_VehicleStateEstimate>{};
  // A live tick while the replay's last one never came: the replay is over all the same.
  if (catch_up_ == CatchUp::Replayed && message.timestamp_ns > replay_end_ns_) finish_replay();
  // A replayed tick: the replayed aiding samples of its instant, by stamp (on_rollback_signal).
  const bool replayed = catch_up_ == CatchUp::Replaying || catch_up_ == CatchUp::Replayed;
  if (replayed) take_replayed_aiding(tick->gyro.t);
  plant::SensorSamples samples = held_;
  samples.gyro = tick->gyro;
  samples.accel = tick->accel;
  held_ = {};
  const flight::EkfCounters before = node_->ekf().counters();
  const bool integrated = node_->on_samples(samples);
  REJUV_ASSERT(integrated, "a sample set with a gyro sample is integrated");
  integrated_ = true;
  last_tick_ns_ = message.timestamp_ns;
  // After DONE a replayed tick's estimate is never published (the kernel drops it only until DONE); the last
  // one ends the replay.
  const bool withheld = catch_up_ == CatchUp::Replayed;
  if (withheld && message.timestamp_ns >= replay_end_ns_) finish_replay();
  // The first live GPS sample after a replay handled whole: its NIS against the replayed estimate's covariance
  // (the filter's own χ² gate) says whether the replay is plausible.
  if (catch_up_ == CatchUp::Judging && samples.gps) {
    if (node_->ekf().last_gps_nis() > params_.gps_gate_chi2) {
      rearm_now(rearm_, true, true);
    } else {
      restored_.reset();
      catch_up_ = CatchUp::Live;
    }
  }
  if (withheld) return std::optional<rejuv_msg_VehicleStateEstimate>{};
  std::uint32_t f = flags(before);
  if (announce_discard_) f |= flight_io::kStateCatchUpDiscarded;
  announce_discard_ = false;
  rejuv_msg_VehicleStateEstimate out = flight_io::vehicle_state_message(*node_, tick->gyro.t, f);
#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK POINT ====
  if (attack_hook_) attack_hook_(out);
#endif
  return std::optional(out);
}

std::uint32_t Ekf2Node::flags(const flight::EkfCounters& before) const {
  const flight::EkfCounters& now = node_->ekf().counters();
  std::uint32_t f = 0;
  if (integrated_) f |= flight_io::kStateAttitudeValid;
  // Position: the filter starts from the known take-off point; it is valid once GPS has confirmed it.
  if (now.gps_fused + now.gps_resets > 0) f |= flight_io::kStatePositionValid;
  if (now.gps_rejected != before.gps_rejected || now.baro_rejected != before.baro_rejected ||
      now.mag_rejected != before.mag_rejected || now.drag_rejected != before.drag_rejected) {
    f |= flight_io::kStateInnovationRejected;
  }
  return f;
}

}  // namespace rejuv::services
