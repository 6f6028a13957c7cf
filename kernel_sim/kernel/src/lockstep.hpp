// Lockstep with the plant (lockstep.cpp; docs/design.md §6): the steps, their rounds, the samples held for their
// step, the pace, and the run's stop conditions. Owns the step clock and the two canonical stages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <variant>

#include "canonical_stage.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "step_clock.hpp"

namespace rejuv::kernel {

// Lockstep: a publication read from a service during a routing round, routed at the end of the round in
// canonical order (publisher id, then arrival); a DDS sample held for its step, routed by (timestamp,
// reader). Publications: key the publisher's ServiceId value, tag the slot. Samples: key (timestamp, reader),
// no tag.
using PublicationStage = CanonicalStage<std::uint32_t, std::uint32_t>;
using SampleStage = CanonicalStage<std::pair<std::uint64_t, std::uint32_t>, std::monostate>;

class Lockstep {
 public:
  explicit Lockstep(Kernel::Impl& kernel) : k(kernel) {}

  [[nodiscard]] Result<void, KernelError> run_lockstep();  // Kernel::run in lockstep with the plant
  void take_steps();       // the SimSteps that arrived, through the bridge's lockstep adapter
  void collect_samples();  // takes every sample reader (lockstep with the plant: on each SimStep)
  void stage_sample(std::size_t reader, std::span<const std::byte> bytes);
  void watch_sample_readers(bool watch);  // lockstep: also wake on samples while a step waits for them
  void begin_step(const PendingStep& step);
  // Advances the active lockstep step by one round when every service is idle; true when it is complete.
  bool advance_step();
  void finish_step();
  [[nodiscard]] Nanos pace_wait();  // how long the next lockstep step must wait for options.speed (0: none)
  void check_stop_conditions();
  // The untimed checkpoint of the alignment that forks every service's first image (docs/design.md §6): asked for at
  // the first step, carried out as any checkpoint but neither timed, counted nor charged.
  void request_priming();
  // The graph idle: the catch-up's next sampling instant routed as a round of its own; at its end, what it
  // cost charged (catch_up.hpp).
  void replay_next_instant();
  bool replay_instant();  // the next instant, or the end of the replay (false): measured and charged

  // Lockstep with the plant: the sample readers are not in epoll, their samples are taken when a SimStep arrives.
  // Chosen once, when the kernel's epoll set is made (create.cpp).
  void set_samples_on_step(bool on) { samples_on_step_ = on; }
  [[nodiscard]] bool samples_on_step() const { return samples_on_step_; }

  // A round's publications (router.cpp): held while the round runs, handed out at its end in canonical order.
  void stage_publication(ServiceId publisher, std::uint32_t slot, std::span<const std::byte> payload) {
    staged_.add(publisher.value(), slot, payload);
  }
  // Calls f(publisher id value, slot, payload) for every staged publication in canonical order, then empties the stage.
  template <typename F>
  void drain_publications(F&& f) {
    staged_.drain(std::forward<F>(f));
  }
  // Drops the staged publications of every publisher (id value) for which `gone` holds: a rollback's retired ones.
  template <typename P>
  void drop_publications_of(P&& gone) {
    staged_.erase_if([&](std::uint32_t publisher, std::uint32_t /*slot*/) { return gone(publisher); });
  }
  [[nodiscard]] std::size_t publications_staged() const { return staged_.size(); }

  // Calls f(key, tag, bytes) for every sample held for the step in canonical order (router.cpp routes them), then
  // empties the stage.
  template <typename F>
  void drain_samples(F&& f) {
    samples_.drain(std::forward<F>(f));
  }

  // The queue, the active step, its rounds and deadlines (step_clock.hpp), for reading: the kernel's manual step,
  // the supervisor's liveness watch and the loop's deadlines ask it. What the others change, they change by the
  // methods below.
  [[nodiscard]] const StepClock& steps() const { return steps_; }
  // Kernel::step (TimeMaster::Manual): a step at `t` queued, as the plant's SimStep would be.
  void offer_manual_step(Nanos t) { steps_.offer_manual(t); }
  // The next queued step begun (begin_step), if one is waiting and none is active; the step begun.
  std::optional<PendingStep> begin_next_step();
  // Samples taken from the bridge's readers, toward the active step's samples_needed.
  void count_samples(std::uint64_t n) { steps_.count_samples(n); }
  // Real time: one more 100 ms of progress counted as a step (the observer's on_step, the stall watch).
  void count_realtime_progress() { steps_.tick(); }
  // The supervisor: `s` killed as hung during the active step; the stall reported once; a hung service killed,
  // the others' idle deadline restarted from `wall_now`; at shutdown, the active step abandoned.
  void note_hung(ServiceId s) { steps_.note_hung(s); }
  void stall_reported() { steps_.stall_reported(); }
  void restart_idle_deadline(Nanos wall_now) { steps_.restart_idle_deadline(wall_now); }
  void abandon_step() { steps_.abandon(); }

 private:
  Kernel::Impl& k;
  StepClock steps_;
  bool samples_on_step_ = false;
  PublicationStage staged_;
  SampleStage samples_;  // the samples of the step (staged here)
  bool watching_samples = false;
  std::optional<std::pair<Nanos, Nanos>> pace_origin{};  // (kernel clock, wall) at the first paced step
};

}  // namespace rejuv::kernel
