// Lockstep (docs/design.md §6; docs/protocol.md "Lockstep with the plant"): the steps of the simulated clock — from
// the plant through the DDS bridge's lockstep adapter (rejuv/dds/plant_lockstep.hpp), or manual
// (Kernel::step) — and what rides on them: the samples a step carries or that came on their own topics, held
// for the step that covers them and routed in canonical order (router.cpp, route_samples); a step's rounds
// until every service is idle; its ack; the untimed priming checkpoint; the run's stop conditions.
#include <algorithm>
#include <string>

#include "images.hpp"

namespace rejuv::kernel {

// ---- samples ----

// Lockstep: a sample is held for the step that covers it, then routed in canonical order (route_samples).
void Lockstep::stage_sample(std::size_t reader, std::span<const std::byte> bytes) {
  const std::uint64_t stamp = dds::plant_topics::stamp_of(bytes).value_or(0);
  samples_.add(std::pair(stamp, static_cast<std::uint32_t>(reader)), std::monostate{}, bytes);
}

// SimSteps from the plant (the step input woke the loop): each becomes a pending step, and the samples it
// carries are staged as if the input that bridges their topic had taken them (the same canonical order as
// samples that came on their own topics, and the same routes).
void Lockstep::take_steps() {
  dds::PlantLockstep* adapter = k.bridge->lockstep();
  REJUV_ASSERT(adapter != nullptr, "only the lockstep adapter has a step input");
  auto n = adapter->take_steps(
      k.bridge->bridge(),
      [&](const dds::PlantLockstep::Step& step) {
        auto offered = steps_.offer(PendingStep{.step = step.step, .t = step.t, .samples_needed = step.samples_needed});
        if (!offered) {
          k.stop_run(StopReason::PlantProtocol, "the plant's steps: " + offered.error() +
                                                    " (a second plant on DDS domain " +
                                                    std::to_string(k.domain) + " in this run's partition " +
                                                    (k.bridge->bridge().partition().empty()
                                                         ? std::string("(the default one)")
                                                         : k.bridge->bridge().partition()) +
                                                    "?)");
        }
      },
      [&](std::size_t input, std::span<const std::byte> bytes) {
        if (!k.stopping) stage_sample(input, bytes);
      });
  if (!n) k.log("DDS take sim_step: %s", n.error().to_string().c_str());
  if (samples_on_step_ && n && *n > 0) collect_samples();
}

void Lockstep::collect_samples() {
  if (!k.bridge) return;
  for (std::size_t i = 0; i < k.bridge->readers().size(); ++i) {
    if (!k.bridge->is_step_input(i)) k.on_dds_ready(i);
  }
}

void Lockstep::watch_sample_readers(bool watch) {
  if (!k.bridge || !samples_on_step_ || watch == watching_samples) return;
  watching_samples = watch;
  for (std::size_t i = 0; i < k.bridge->readers().size(); ++i) {
    if (k.bridge->is_step_input(i)) continue;
    dds::Reader& reader = k.bridge->readers()[i].reader;
    reader.set_signalling(watch);  // on before the fd is watched; the collect_samples below takes the rest
    if (watch) {
      (void)k.epoll.add(reader.ready_fd(), token(Source::Dds, i));
    } else {
      (void)k.epoll.remove(reader.ready_fd());
    }
  }
  if (watch) collect_samples();
}

// ---- steps ----

std::optional<PendingStep> Lockstep::begin_next_step() {
  auto next = steps_.begin_next(k.wall());
  if (next) begin_step(*next);
  return next;
}

// The step StepClock::begin_next made active.
void Lockstep::begin_step(const PendingStep& step) {
  k.router.new_step();
  k.set_now(step.t);
  if (!k.router.sr_mode_announced()) k.router.publish_sr_mode();
  request_priming();
  k.rejuvenator.fire_rejuvenation();  // docs/design.md §7: a due rejuvenation timer rolls back before anything else
                                      // of the step
  (void)k.rejuvenator.service_images();
  // docs/design.md §6: set the clock, fire due timers, route the step's samples; then rounds until idle. Each
  // service gets the round's frames in one batch (router.cpp, cork).
  k.router.cork();
  k.fire_timers();
  k.router.route_samples();
  k.router.uncork();
  k.net_poll();  // datagrams that arrived before the step: handed over at its start (netgate.cpp)
}

// The catch-up's next sampling instant (catch_up.hpp), once the graph is idle: routed as a batch of its own.
void Lockstep::replay_next_instant() {
  if (!k.rejuvenator.catch_up().replaying()) return;
  // The kernel's own bound (catch_up.hpp), checked between instants: the graph is idle here, so the chain has
  // nothing of the replay left to handle and returns to its real-time plan at once.
  if (k.rejuvenator.catch_up().past_bound(k.wall(), CatchUp::kReplayBoundLockstep)) {
    k.cut_catch_up_short();
    k.rejuvenator.catch_up_drained();
    return;
  }
  steps_.next_batch(k.wall());  // its rounds and idle deadline count from here
  k.router.cork();
  (void)replay_instant();  // the last call ends the replay (advance_step then sees it over)
  k.router.uncork();
}

bool Lockstep::replay_instant() {
  // This call ends the replay, handled whole (the chain answered Idle, or the graph was idle): DONE is published
  // ahead of the live samples it releases, so that it reaches the estimator first.
  if (k.rejuvenator.catch_up().replaying() && !k.rejuvenator.catch_up().replay_pending()) {
    k.rejuvenator.signal_catch_up(rejuv_msg_CATCH_UP_DONE);
  }
  const bool more = k.rejuvenator.replay_catch_up_instant(
      [&](ObjectId topic, std::span<const std::byte> bytes) {
        k.router.publish_as_kernel(topic, bytes, Router::From::Replay);
      },
      [&](ObjectId topic, std::span<const std::byte> bytes) {
        k.router.publish_as_kernel(topic, bytes, Router::From::Held);
      });
  if (!more) {
    k.rejuvenator.catch_up_done();
  }
  return more;
}

bool Lockstep::advance_step() {
  for (;;) {
    if (k.rejuvenator.service_images())
      continue;  // a pending rollback, or a checkpoint once quiescent (rejuvenator.cpp)
    if (!k.all_idle()) return false;
    if (steps_.rounds_exhausted()) {
      k.log("step %llu did not settle after %u routing rounds; ending it",
            static_cast<unsigned long long>(steps_.active()->step), steps_.rounds());
      return true;
    }
    if (!staged_.empty()) {
      steps_.next_round();
      k.router.cork();
      k.router.flush_staged();
      k.router.uncork();
      continue;
    }
    // Timers armed during this step that are already due (e.g. after(0)).
    if (k.timers.next_due() && *k.timers.next_due() <= k.now()) {
      steps_.next_round();
      k.router.cork();
      k.fire_timers();
      k.router.uncork();
      continue;
    }
    // After a rollback the restored estimator chain catches up before the step goes on (the world is stopped,
    // the replay charged).
    if (k.rejuvenator.catch_up().replaying()) {
      replay_next_instant();
      continue;
    }
    return true;
  }
}

void Lockstep::finish_step() {
  const PendingStep step = steps_.finish(k.wall());
  const Nanos charged = k.rejuvenator.take_step_charge();
  if (dds::PlantLockstep* adapter = k.bridge ? k.bridge->lockstep() : nullptr; adapter != nullptr) {
    if (auto ok = adapter->write_ack(step.step, step.t, charged); !ok) {  // docs/design.md §6: charge, in simulated time
      const std::string error = ok.error().to_string();
      k.log("%s", error.c_str());
      k.stop_run(StopReason::PlantExited, error);
    }
  }
  if (k.observer != nullptr) k.observer->on_step(step.step, step.t, k.caps.mode());
  check_stop_conditions();
}

Nanos Lockstep::pace_wait() {
  if (!k.options.speed || !(*k.options.speed > 0.0)) return Nanos{0};
  if (!pace_origin) {
    pace_origin = std::pair(k.now(), k.wall());
    return Nanos{0};
  }
  const auto simulated = static_cast<double>((k.now() - pace_origin->first).count());
  const Nanos due = pace_origin->second + Nanos{static_cast<std::int64_t>(simulated / *k.options.speed)};
  return std::max(Nanos{0}, due - k.wall());
}

// docs/design.md §6: the first images of every service are forked during the alignment, untimed, so that the
// checkpoints of the flight all take theirs by written pages. Once, at the first step of a run with a plant
// (lockstep or realtime); never in manual stepping, whose tests count their generations.
void Lockstep::request_priming() {
  if (!k.sr || k.options.time_master != TimeMaster::Plant || !k.graph.graph.has_plant()) return;
  (void)k.rejuvenator.request_priming();  // once per run, while nothing else is asked
}

void Lockstep::check_stop_conditions() {
  if (k.options.duration && k.now() >= *k.options.duration) {
    k.stop_run(StopReason::Duration, "t = " + std::to_string(to_seconds(k.now()).count()) + " s");
  }
  const Seconds timeout =
      launch::mission_timeout(k.graph.graph.mission());  // of the flight, after the alignment
  if (timeout.count() > 0 && k.now() >= k.rejuvenator.flight_start() + to_nanos(timeout)) {
    const proto::Mission& path = k.graph.graph.mission();
    k.stop_run(StopReason::MissionTimeout,
               "mission not completed within " + std::to_string(timeout.count()) + " s" +
                   (path.has_timeout_s()
                        ? std::string()
                        : " (derived from the path's " + std::to_string(launch::path_length_m(path)) +
                              " m: set mission.timeout_s for a slower scheme)"));
  }
}

// Kernel::run in lockstep with the plant: a step begins once every sample it counts has arrived, runs its
// rounds until the graph is idle, and is acknowledged; the loop sleeps in between.
Result<void, KernelError> Lockstep::run_lockstep() {
  for (;;) {
    if (k.stop && (!graceful(*k.stop) || !steps_.active())) break;
    // A sample DDS never delivers must not stall the run: after a second the step goes on without it.
    if (const auto gave_up = steps_.give_up_on_samples(k.wall(), std::chrono::seconds{1})) {
      k.log("step %llu: %llu sensor sample(s) never arrived; the step goes on without them",
            static_cast<unsigned long long>(gave_up->step),
            static_cast<unsigned long long>(gave_up->missing));
    }
    if (!k.stop) {
      if (const Nanos wait = pace_wait(); wait > Nanos{0}) {  // --speed: events are handled meanwhile
        if (auto ok = k.pump(wait); !ok) return ok;
        continue;
      }
      (void)begin_next_step();
    }
    if (steps_.active() && advance_step()) {
      finish_step();
      continue;  // the next step may already be waiting
    }
    // A step whose samples are not all in yet (DDS orders per writer only): wake on the sample readers too
    // until they are.
    const bool short_of_samples = steps_.short_of_samples();
    watch_sample_readers(short_of_samples);
    if (auto ok =
            k.pump(short_of_samples ? std::optional<Nanos>(std::chrono::milliseconds{100}) : std::nullopt);
        !ok) {
      return ok;
    }
  }
  return {};
}

}  // namespace rejuv::kernel
