// What a checkpoint or a rollback costs the plant's world in simulated time (docs/design.md §6; the paper's Table I
// times its checkpoint and rollback as time the controls are held). In lockstep with the model's charge (the
// default) it is the launch file's model, so that a run with one seed is deterministic; with --charge measured
// it is the real duration, and in real time the world simply went on meanwhile. The charge accumulates over
// the lockstep step in progress and leaves with its ack (lockstep.cpp, finish_step). One owner: the image
// coordinator charges (checkpoint.cpp, rollback.cpp; the catch-up after a rollback, router.cpp); the lockstep takes.
#pragma once

#include <utility>

#include "rejuv/core/time.hpp"
#include "rejuv/kernel/kernel.hpp"

namespace rejuv::kernel {

class ImageCharge {
 public:
  ImageCharge() = default;
  ImageCharge(ClockMode clock_mode, KernelOptions::Charge charge, Nanos checkpoint_model, Nanos rollback_model,
              Nanos catch_up_model_per_sample)
      : lockstep_(clock_mode == ClockMode::Lockstep),
        measured_(charge == KernelOptions::Charge::Measured),
        checkpoint_model_(checkpoint_model),
        rollback_model_(rollback_model),
        catch_up_model_per_sample_(catch_up_model_per_sample) {}

  // Whether the vehicle lives through the real duration of the image work: real time, or lockstep charging the
  // measured duration. Then the kernel may wait only resume_deadline for images (KernelOptions).
  [[nodiscard]] bool vehicle_sees_work() const { return !lockstep_ || measured_; }
  void checkpoint(Nanos took, SrStats& stats) { add(took, checkpoint_model_, stats); }
  void rollback(Nanos took, SrStats& stats) { add(took, rollback_model_, stats); }
  // The estimate catch-up after a rollback (catch_up.hpp): part of the rollback's stop, modelled per sample.
  void catch_up(Nanos took, std::uint64_t samples, SrStats& stats) {
    add(took, catch_up_model_per_sample_ * static_cast<std::int64_t>(samples), stats);
  }
  // The step's charge, for its ack; the next step starts from zero.
  [[nodiscard]] Nanos take_step_charge() { return std::exchange(step_, Nanos{0}); }

 private:
  void add(Nanos measured, Nanos modelled, SrStats& stats) {
    stats.measured += measured;
    if (!lockstep_) return;
    const Nanos charged = measured_ ? measured : modelled;
    step_ += charged;
    stats.charged += charged;
  }
  bool lockstep_ = true;
  bool measured_ = false;
  Nanos checkpoint_model_{0};
  Nanos rollback_model_{0};
  Nanos catch_up_model_per_sample_{0};
  Nanos step_{0};  // charged to the lockstep step in progress
};

}  // namespace rejuv::kernel
