// The `ekf2` service (docs/design.md §9, paper §IV-B): sensor_combined + sensor_mag + sensor_baro + sensor_gps →
// the simulation's estimator node (flight::EstimatorNode, the EKF) → vehicle_state.
//
// Topics: in sensor_combined (250 Hz, from sensors), sensor_mag and sensor_baro (50 Hz), sensor_gps (10 Hz,
// 200 ms old), all raw ones bridged in from the plant, and rollback_signal (the kernel, after a rollback;
// only if the policy grants it); out vehicle_state (VehicleStateEstimate) once per IMU tick, stamped with the
// tick's time. Params (graph-wide, flight_io/params.hpp): mission.* — the EKF
// starts where the simulation starts it, hovering at the first waypoint; the noise model is the
// simulation's (flight_io::ekf_params()).
//
// Order of fusion, as in the simulation: within one IMU tick the estimator predicts with the IMU first and
// then fuses GPS, baro and mag (EstimatorNode::on_samples). The raw samples reach this service before the
// sensor_combined of their tick (that one takes a detour through `sensors`), so they are held and handed to
// the estimator together with the next IMU tick. A second sample of one sensor before that tick flushes the
// held ones without a prediction — what the simulation does with a physics step that has no gyro sample.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "rejuv/flight/estimator_node.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::sdk {
class Service;
}  // namespace rejuv::sdk

namespace rejuv::services {

class Ekf2Node {
 public:
  Ekf2Node(const flight::EkfParams& params, const flight::EkfState& initial, Nanos imu_period);
  // After a cold restart (docs/design.md §7) the vehicle is wherever the mission had taken it, not at its take-off
  // point: the filter starts from the first GPS fix (position predicted over the fix's delay, its velocity)
  // with `attitude` (the hover is level; the heading the kept x_sp says) and publishes nothing before it.
  [[nodiscard]] static Ekf2Node from_first_fix(const flight::EkfParams& params, const Eigen::Quaterniond& attitude,
                                               Nanos imu_period);

  // Raw aiding samples: held until the next IMU tick. Non-finite ones (and GPS without a 3D fix) are refused.
  Result<void, flight_io::InputFailure> on_mag(const rejuv_msg_SensorMag& message);
  Result<void, flight_io::InputFailure> on_baro(const rejuv_msg_SensorBaro& message);
  Result<void, flight_io::InputFailure> on_gps(const rejuv_msg_SensorGps& message);

  // One IMU tick: predict, fuse the held samples, and return the estimate to publish (nullopt: waiting for
  // the first GPS fix, from_first_fix).
  [[nodiscard]] Result<std::optional<rejuv_msg_VehicleStateEstimate>, flight_io::InputFailure> on_combined(
      const rejuv_msg_SensorCombined& message);

  // RollbackSignal (docs/design.md §7 step 3): this image was just restored; its estimate is T_MC + T_RB old. As the
  // simulation does: the held samples (from before the cut) are dropped and the filter's uncertainty re-armed
  // (EstimatorNode::on_rollback), so that the measurements pull the estimate back within T_est.
  void on_rollback(const flight::EkfRearm& rearm);

  // A rollback_signal with the estimate catch-up (its `catch_up`; idl/sr.idl EstimateCatchUp; docs/control.md
  // §6.3). REPLAY: the held samples dropped, the covariance kept, the restored filter remembered; the replay's
  // aiding samples are then fused with the IMU tick of their own instant, by stamp (on_replayed_aiding), not with
  // whichever tick comes next: in real time the kernel's samples reach ekf2 ahead of the ticks that take the
  // detour through `sensors`, and a GPS sample fused before the replayed IMU would test the restored state, not
  // the replayed one. DONE: the replay is over once its last tick (replayed_to_ns) is integrated — no estimate is
  // published in between; then a GPS sample of the replay that failed its χ² gate discards the replayed
  // estimate, and otherwise the first live GPS sample's NIS above the gate (p = 1e-4) does: discarded for the
  // restored filter re-armed (`rearm`'s 1σ values), the paper's scheme (§IV). REARM: the replay could not be
  // used (cut short): the restored filter re-armed now (a replay not judged whole is not trusted in part), and
  // the chain's late output of the replay (sensor_combined stamped up to replayed_to_ns) ignored. OFF:
  // on_rollback(rearm).
  void on_rollback_signal(const rejuv_msg_RollbackSignal& signal, const flight::EkfRearm& rearm);
  // Replayed estimates discarded for a re-arm so far (this incarnation).
  [[nodiscard]] std::uint32_t catch_up_discarded() const { return discarded_; }

  // Precondition: started (started()).
  [[nodiscard]] const flight::EstimatorNode& node() const { return *node_; }
  // x̂ as the controllers will read it from vehicle_state. Precondition: started().
  [[nodiscard]] const flight::StateVec& estimate() const { return node_->estimate(); }
  // False only while a node made by from_first_fix waits for its first GPS fix.
  [[nodiscard]] bool started() const { return node_.has_value(); }

#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK (test builds only; estimate_attack.hpp) ====
  // Sees every estimate on its way out and may change it (a compromised ekf2). A rollback wipes whatever the
  // hook holds, like any other corruption of the image.
  using EstimateHook = std::function<void(rejuv_msg_VehicleStateEstimate&)>;
  void set_attack_hook(EstimateHook hook) { attack_hook_ = std::move(hook); }
#endif

 private:
  // Fuses the held samples without a prediction (a second sample of a sensor arrived before the IMU tick).
  void flush_held();
  [[nodiscard]] std::uint32_t flags(const flight::EkfCounters& before) const;

  Ekf2Node(const flight::EkfParams& params, const Eigen::Quaterniond& attitude, Nanos imu_period);

  // The catch-up's test of a replayed estimate (on_rollback_signal). Replaying: REPLAY seen; Replayed: DONE
  // seen, the replay's last ticks still to come; Judging: the replayed GPS samples all passed, the first live
  // one decides.
  enum class CatchUp : std::uint8_t { Live, Replaying, Replayed, Judging };
  // An aiding sample of the replay (one of mag, baro, gps set), fused with the first tick stamped at or after
  // `due` (a GPS sample is gps_delay old when it arrives: due at its stamp + gps_delay).
  struct ReplayedAiding {
    Nanos due{0};
    plant::SensorSamples sample;
  };
  void on_replayed_aiding(Nanos due, plant::SensorSamples sample);
  // The replayed aiding samples due by the tick stamped `t`, in the held set (a second one of a sensor flushes
  // the set first, as live).
  void take_replayed_aiding(Nanos t);
  // DONE seen and the replay's last tick integrated: the replayed estimate judged (or left to the first live GPS).
  void finish_replay();
  [[nodiscard]] bool replay_failed_gate() const;
  void rearm_now(const flight::EkfRearm& rearm, bool from_restored, bool implausible);

  flight::EkfParams params_;
  Nanos imu_period_;
  CatchUp catch_up_ = CatchUp::Live;
  std::optional<flight::EstimatorNode> restored_;  // the filter as restored, kept while its replay is judged
  std::uint32_t gps_rejected_at_restore_ = 0;
  flight::EkfRearm rearm_{};                        // the 1σ values of the re-arm a discard makes
  std::uint64_t stale_until_ns_ = 0;                // sensor_combined stamped up to this is the replay's, late
  std::uint64_t replay_end_ns_ = 0;                 // DONE: the stamp of the replay's last sample
  std::uint64_t last_tick_ns_ = 0;                  // the stamp of the last tick integrated
  std::vector<ReplayedAiding> replayed_aiding_;     // Replaying: aiding samples not due yet, in stamp order
  std::uint32_t discarded_ = 0;
  bool announce_discard_ = false;                   // the next estimate carries kStateCatchUpDiscarded
  Eigen::Quaterniond waiting_attitude_ = Eigen::Quaterniond::Identity();  // from_first_fix, until the fix
  std::optional<flight::EstimatorNode> node_;
  plant::SensorSamples held_;  // aiding samples only (mag, baro, gps)
  bool integrated_ = false;    // at least one IMU tick
#if defined(REJUV_ATTACK_HOOKS)
  EstimateHook attack_hook_;
#endif
};

// The attack library on ekf2 (docs/control.md "Attack library", flight/attack_library.hpp): ESTIMATE_SHIFT and
// ESTIMATE_DRIFT, a compromised estimator that publishes x̂ + offset in attacked MC windows — false data on the
// topic every controller reads. The offset and the window live in this process's memory (the hook of
// Ekf2Node), so the rollback to the clean image erases them. Armed at boot by services::arm_attack
// (service_main.hpp), which calls this in a test build; defined in estimate_attack.cpp.
// Reads the plan (attack.*), and if it names ESTIMATE_SHIFT or ESTIMATE_DRIFT installs the hook. False (the
// error logged) on bad params: the service refuses to boot.
[[nodiscard]] bool arm_library_attack(sdk::Service& svc, Ekf2Node& node);
// The message as x̂ + offset would be published: p, v, ω shifted, the attitude rebuilt from the shifted Euler
// angles (ZYX, the inverse of flight::euler_from_quaternion), so that state_from_message reads x̂ + offset.
void shift_estimate(rejuv_msg_VehicleStateEstimate& m, const flight::StateVec& offset);

}  // namespace rejuv::services
