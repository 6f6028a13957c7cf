// The metrics of a run on the multi-process runtime, measured from what the kernel routes (ground truth from
// the plant, the estimate, the setpoint, the actuator controls and outputs, the SR mode) with the same path,
// ellipsoid P and control design as `rejuv sim` (rejuv_sr_sim / rejuv_control), so the two runners compare
// directly. `rejuv run` and the multi-process end-to-end tests (tests/multiproc) both use this one recorder.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>

#include "attack_ledger.hpp"
#include "figure_data.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/setpoint.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/flight_io/messages.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

// What a runtime run is measured against: `rejuv sim`'s configuration of the same graph and seed.
struct RunReference {
  flight::ControlDesign design;
  flight::WaypointPath path;
  Nanos alignment{0};    // the plant's pre-flight alignment (launch lockstep.alignment_s), as long as the model's
  double lost_V = 100;   // V above which the vehicle is lost and the run ends (flight::SimConfig::lost_V)
  // The plan's attack on the vehicle when it is a law of the attack library (not the worst-case control): it
  // acts through another service (an estimate, a sensor, x_sp, the gain), so the controls carry no signature
  // of it; its MC windows are counted by the plan (start, max_windows), as the model counts them.
  std::optional<flight::AttackConfig> library_attack{};
};
// From the graph and the seed (nullopt: the graph's). The error is a message for the user (bad input).
[[nodiscard]] Result<RunReference, std::string> run_reference(const launch::LoadedLaunch& graph,
                                                              std::optional<std::uint64_t> seed);

// When the vehicle was declared lost.
struct VehicleLost {
  Nanos t{0};     // flight time (after the alignment)
  double V = 0;   // ‖x − x_sp‖²_P then (inf/nan: the state was not finite)
};

// Records the run from the routed publications: tracking error against the waypoint polyline (ground truth),
// V = ‖x − x_sp‖²_P, the estimation error ‖x − x̂‖²_P, gaps between actuator outputs, the attacked MC
// windows, the CSV trace (the same columns as `rejuv sim --csv`) and progress lines on stderr. Everything
// starts at the end of the plant's pre-flight alignment, like `rejuv sim`'s t = 0 after its alignment.
class RunRecorder final : public kernel::Observer {
 public:
  enum class Progress : std::uint8_t { Off, Every10s, Every1s };

  // `csv`: the trace, or nullptr. Not owned; must outlive the recorder's use.
  RunRecorder(RunReference reference, std::FILE* csv, Progress progress);

  // Called once, from the kernel's loop, when V first exceeds the reference's lost_V (or the state stops
  // being finite): `rejuv sim`'s rule, so that a run without SR under attack ends like the model's does.
  // `rejuv run` and the tests pass Kernel::request_stop.
  void on_vehicle_lost(std::function<void()> stop) { stop_ = std::move(stop); }
  // The launch's stop_after_attacks (`rejuv sweep --attacks N`, §VI-D): `stop` is called once, when the
  // first controls of an MC window arrive after `attacks` attacked windows (the last one's secure interval
  // flown, as `rejuv sim` stops). 0 = never.
  void stop_after_attacks(std::uint64_t attacks, std::function<void()> stop) {
    stop_after_ = attacks;
    stop_attacks_ = std::move(stop);
  }

  // `--out DIR` (figure_data.hpp): the trace, every control update and SR event (flight time: after the
  // alignment) also go to `files`. Not owned; nullptr: none.
  void record_to(RunFiles* files) { files_ = files; }
  // The plan's attacks, counted by kind into the summary's attacks_by_kind (attack_ledger.hpp).
  void track_attacks(AttackLedger ledger) { attack_ledger_.emplace(std::move(ledger)); }

  void on_publication(const kernel::Publication& p) override;
  void on_step(std::uint64_t step, Nanos t, SrMode mode) override;
  void on_control_update(Nanos t, Nanos wall) override;
  void on_sr_event(const SrEvent& event) override;

  // The metrics into the summary (mission, tracking, safety, control gap, attacks); `end` is the kernel
  // time at which the run stopped.
  void fill(proto::RunSummary& s, Nanos end) const;

  [[nodiscard]] const std::optional<VehicleLost>& lost() const { return lost_; }
  [[nodiscard]] bool stopped_after_attacks() const { return stopped_after_attacks_; }
  // MC windows seen, one per epoch in which the kernel published mode MC (with SR: each one opened by one
  // arm of the rejuvenation timer, §V-A), counted from the start of the run (alignment included).
  [[nodiscard]] std::uint64_t mc_windows() const { return mc_windows_; }
  // MC windows after the alignment in which the mission controller's controls were, for most of the window,
  // the worst-case corner of Ū for the estimate and setpoint it was given (§VI-D: the attack of the plan).
  [[nodiscard]] std::uint64_t attacked_windows() const;

 private:
  void on_truth(const rejuv_msg_GroundTruth& g, Nanos t);
  void on_mc_controls(const flight::InputVec& u, Nanos stamp, std::uint32_t epoch);
  void declare_lost(Nanos t, double V);

  RunReference ref_;
  std::FILE* csv_;
  RunFiles* files_ = nullptr;
  std::optional<AttackLedger> attack_ledger_;
  ControlIntervals intervals_;              // every run: the intervals holding a checkpoint or a rollback
  kernel::DurationSamples at_cp_ms_, at_rb_ms_;
  Progress progress_;
  std::function<void()> stop_;
  std::uint64_t stop_after_ = 0;
  std::function<void()> stop_attacks_;
  bool stopped_after_attacks_ = false;
  flight::StateVec x_ = flight::StateVec::Zero();
  std::optional<flight::StateVec> x_hat_;
  Nanos x_hat_stamp_{-1};
  std::optional<flight::StateVec> x_sp_;
  flight::InputVec u_ = flight::InputVec::Zero();
  SrMode mode_ = SrMode::MC;
  double d_sum_ = 0, d_max_ = 0, max_V_ = 0, max_est_err_ = 0;
  std::uint64_t d_count_ = 0;
  std::optional<Nanos> completed_at_;
  std::optional<Nanos> last_output_;
  Nanos max_gap_{0};
  Nanos last_progress_{0};
  std::optional<VehicleLost> lost_;
  // MC windows (by epoch) and the attack classification of the current one.
  std::optional<std::uint32_t> last_mc_epoch_;
  std::uint64_t mc_windows_ = 0;
  struct Window {
    std::uint32_t epoch = 0;
    std::uint64_t samples = 0;  // controls matched to the estimate they were computed from
    std::uint64_t corners = 0;  // … of which were the worst-case corner
    bool planned = false;       // a window the library attack acts in (by the plan)
  };
  std::optional<Window> window_;
  std::uint64_t attacked_closed_ = 0;  // attacked windows already closed
  std::uint64_t planned_windows_ = 0;  // windows the library attack was planned for so far
  [[nodiscard]] bool window_attacked(const Window& w) const;
};

}  // namespace rejuv::cli
