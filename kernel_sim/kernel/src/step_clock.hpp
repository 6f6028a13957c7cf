// The steps of the lockstep clock (docs/design.md §6; docs/protocol.md "Lockstep with the plant"): the queue of steps
// offered by the plant (SimStep, through the bridge's lockstep adapter) or by Kernel::step (manual), the count
// of the samples they wait for, the active step and its routing rounds, and the wall-clock references of its
// deadlines. One owner: the kernel's lockstep (lockstep.cpp) drives it. Besides reading its deadlines, the loop
// (loop.cpp) counts the samples that arrive (count_samples) and the steps done (tick), and the supervisor
// (supervisor.cpp) notes a hung service (note_hung), a reported stall (stall_reported), a restarted idle deadline
// after a kill (restart_idle_deadline) and a step given up at shutdown (abandon) — each through a method here.
// What a step does — the clock, timers, samples, rounds until idle, the ack — is lockstep.cpp's.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::kernel {

inline constexpr std::uint32_t kMaxRoundsPerStep = 256;  // a step that never settles is cut here
inline constexpr Nanos kStallReportAfter{std::chrono::seconds{3}};  // no step completed: say why (report_stall)

// A SimStep from the plant (or a manual step).
struct PendingStep {
  std::uint64_t step = 0;
  Nanos t{0};
  std::uint64_t samples_needed = 0;  // samples counted before it (SimStep.samples_published)
};

class StepClock {
 public:
  // ---- the queue ----
  // A plant's step (SimStep): refused, and not queued, unless it follows the last one offered — the next
  // number, later in time. A SimStep of another plant on the same DDS domain would otherwise move the clock
  // back and route that plant's samples as this vehicle's.
  [[nodiscard]] Result<void, std::string> offer(const PendingStep& step) {
    if (last_offered_ && (step.step != last_offered_->step + 1 || step.t <= last_offered_->t)) {
      return fail("step " + std::to_string(step.step) + " at t = " + std::to_string(step.t.count()) +
                  " ns does not follow step " + std::to_string(last_offered_->step) + " at t = " +
                  std::to_string(last_offered_->t.count()) + " ns");
    }
    last_offered_ = step;
    pending_.push_back(step);
    return {};
  }
  // Kernel::step: a step numbered here, waiting for no sample.
  void offer_manual(Nanos t) { pending_.push_back(PendingStep{.step = next_manual_++, .t = t, .samples_needed = 0}); }
  void count_samples(std::uint64_t n) { samples_received_ += n; }
  // Whether the next step waits for samples that have not arrived yet (DDS orders per writer only).
  [[nodiscard]] bool short_of_samples() const {
    return !active_ && !pending_.empty() && samples_received_ < pending_.front().samples_needed;
  }
  // A sample DDS never delivers must not stall the run: once the next step has been short of samples for
  // `patience`, the count is re-synchronised (so that the next steps do not wait for it either). Says which
  // step gave up on how many samples.
  struct GaveUp {
    std::uint64_t step = 0;
    std::uint64_t missing = 0;
  };
  std::optional<GaveUp> give_up_on_samples(Nanos wall_now, Nanos patience) {
    if (!short_of_samples()) return std::nullopt;
    if (!short_since_) short_since_ = wall_now;
    if (wall_now - *short_since_ <= patience) return std::nullopt;
    const GaveUp gave_up{.step = pending_.front().step, .missing = pending_.front().samples_needed - samples_received_};
    samples_received_ = pending_.front().samples_needed;
    return gave_up;
  }
  // The next step, if none is active and its samples are in: it becomes the active step, begun at wall_now.
  std::optional<PendingStep> begin_next(Nanos wall_now) {
    if (active_ || pending_.empty() || short_of_samples()) return std::nullopt;
    short_since_.reset();
    active_ = pending_.front();
    pending_.erase(pending_.begin());
    rounds_ = 0;
    started_ = wall_now;
    hung_.clear();
    return active_;
  }

  // ---- the active step ----
  [[nodiscard]] const std::optional<PendingStep>& active() const { return active_; }
  [[nodiscard]] std::uint32_t rounds() const { return rounds_; }
  [[nodiscard]] bool rounds_exhausted() const { return rounds_ >= kMaxRoundsPerStep; }
  void next_round() { ++rounds_; }
  // A new batch of input inside the active step (a sampling instant the catch-up replays, catch_up.hpp): its
  // rounds and its idle deadline count from here, so that a long replay is not taken for a step that never
  // settles or for a hung service.
  void next_batch(Nanos wall_now) {
    rounds_ = 0;
    started_ = wall_now;
  }
  void note_hung(ServiceId s) {
    if (active_) hung_.push_back(s);
  }
  [[nodiscard]] const std::vector<ServiceId>& hung() const { return hung_; }
  // The active step is done: counted, and its end is where the stall deadline starts again.
  PendingStep finish(Nanos wall_now) {
    const PendingStep step = *active_;
    active_.reset();
    ++steps_done_;
    last_done_ = wall_now;
    stall_reported_ = false;
    return step;
  }
  // At shutdown: the active step is dropped, neither counted nor acknowledged.
  void abandon() { active_.reset(); }
  // Realtime: a progress tick of the kernel clock counts as a step (Observer::on_step).
  void tick() { ++steps_done_; }
  [[nodiscard]] std::uint64_t steps_done() const { return steps_done_; }

  // ---- deadlines (wall clock) ----
  // The active step's services must be idle by then (KernelOptions::idle_deadline).
  [[nodiscard]] std::optional<Nanos> idle_deadline(Nanos bound) const {
    return active_ ? std::optional<Nanos>(started_ + bound) : std::nullopt;
  }
  void restart_idle_deadline(Nanos wall_now) { started_ = wall_now; }  // a hung service was killed
  // No step has completed for kStallReportAfter: once per stall, after the first step.
  [[nodiscard]] std::optional<Nanos> stall_deadline() const {
    return !stall_reported_ && last_done_ > Nanos{0} ? std::optional<Nanos>(last_done_ + kStallReportAfter)
                                                     : std::nullopt;
  }
  [[nodiscard]] Nanos last_done() const { return last_done_; }
  void stall_reported() { stall_reported_ = true; }
  // What the queue waits for when no step is active (report_stall).
  [[nodiscard]] std::string waiting_for() const {
    if (pending_.empty()) return "no SimStep from the plant";
    return "step " + std::to_string(pending_.front().step) + " waits for samples: " +
           std::to_string(samples_received_) + " of " + std::to_string(pending_.front().samples_needed);
  }

 private:
  std::vector<PendingStep> pending_;
  std::optional<PendingStep> last_offered_;  // the plant's last step (offer)
  std::optional<PendingStep> active_;
  std::uint64_t samples_received_ = 0;
  std::optional<Nanos> short_since_;  // wall time the next step began to wait for missing samples
  std::uint32_t rounds_ = 0;
  Nanos started_{0};                  // wall time the active step began (or its idle deadline restarted)
  Nanos last_done_{0};                // wall time the last step completed
  bool stall_reported_ = false;
  std::vector<ServiceId> hung_;       // services killed as hung during the active step
  std::uint64_t steps_done_ = 0;
  std::uint64_t next_manual_ = 0;
};

}  // namespace rejuv::kernel
