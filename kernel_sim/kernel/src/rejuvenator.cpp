// Rejuvenator (rejuvenator.hpp): the image coordinator (docs/design.md §7; the paper's §V create_checkpoint /
// rollback, which took ≈20 ms and ≈15 ms in the PX4 kernel module): checkpoint and rollback of the rejuvenated
// services with the queue state beside them. Its files:
//   rejuvenator.cpp         safe points (where a checkpoint or rollback runs), socket pairs made ahead,
//                           retired generations and reaping, the rejuvenation timer, modes and SR events
//   checkpoint.cpp          checkpoint g: Snapshot, Taken / TakenPages, the commit, images by written pages
//   rollback.cpp            rollback to the newest intact generation, falling back; the cold restart
//   checkpointed_state.cpp  the kernel state saved beside the images, one value (image::CheckpointedState)
//
// Checkpoint g (the caller — checkpoint_p in CP — invoked CheckpointCreate and waits for its Reply):
//   1. At a quiescent point (lockstep: every other service idle; every channel drained) routing freezes:
//      publications still land in the rings but nothing is delivered, so no service reads past the cut.
//   2. Every live rejuvenated service gets Snapshot{g, base} with a fresh resume socket. Where it can, it
//      copies the pages written since `base` into a sealed memfd and answers TakenPages (after the commit a
//      copy of base's image makes g's from them: send_patches); otherwise it forks its image (the kernel's
//      child, clone(CLONE_PARENT)) and answers Taken{g, pid}. The caller takes its image inside its call.
//   3. Publications that arrive before their sender's Taken belong before the cut: they are applied to the
//      rings, undelivered. Then the kernel state — the rings, generations, cursors, each service's
//      subscriptions and timers and t_cp — is saved beside the images as one value (save_state); the
//      oldest generation beyond K is discarded; the caller gets its Reply (Taken in the live process);
//      routing resumes.
// Rollback (the rejuvenation timer, a CheckpointRollback, a rejuvenated service lost):
//   1. Mode RB (network revoked). Every live rejuvenated service is cut off (its channel out of the loop,
//      closed after the timed part) and killed with its cgroup leaf (cgroup.kill), or, without it, stopped
//      (SIGSTOP) and killed once the rollback is over (Reaper).
//   2. Each image of the newest intact generation gets Resume{g, epoch} with a new channel; the frozen copy
//      that reads it answers Resumed{g, its pid} on the new channel; a Fork afterwards makes a new spare.
//   3. The kernel state is restored whole (restore_state; periodic and one-shot timers shifted by now − t_cp);
//      rollback_signal and sr_mode are published; routing resumes. Driver-level services (output_driver) are
//      never touched: the broker re-bases their cursors to the restored head.
// Faults: a refused or late Taken abandons the generation (a late service is killed, which is itself a
// rollback trigger); a dead image or a failed resume falls back to the previous generation, then to a cold
// restart of the rejuvenated services from their binaries in SC (network off). Every path is logged.
#include <fcntl.h>

#include <algorithm>
#include <limits>
#include <csignal>
#include <utility>

#include "images.hpp"

namespace rejuv::kernel {

// The links to other hosts close before the capabilities change at MC → RB and open after them at CP → MC
// (link_guard.hpp), so that nothing crosses in the secure interval (§III, §IV-D).
void Rejuvenator::open_links() { links_.create(link_hosts(k), k.caps.mode()); }

bool Rejuvenator::enter_mode(SrMode mode) {
  const SrMode from = k.caps.mode();
  links_.before_mode(from, mode);
  const auto changed = k.caps.apply_mode(mode);
  // Changed or refused: the Mode event that follows says which mode holds now.
  mode_changed_ = Stamp{.t = k.now(), .wall = k.wall()};
  if (!changed) {
    k.log("mode %s: %s", std::string(to_string(mode)).c_str(),
          std::string(cap::to_string(changed.error())).c_str());
    links_.after_mode(from, mode, false);
    return false;
  }
  k.kernel_clock.show_mode(k.caps.mode());
  links_.after_mode(from, mode, true);
  return true;
}

void Rejuvenator::set_mode(SrMode mode, std::optional<ServiceId> by) {
  if (!enter_mode(mode)) return;
  k.router.publish_sr_mode();
  sr_event(SrEventKind::Mode, {}, {}, by);
}

void Rejuvenator::sr_event(SrEventKind kind, Generation g, Nanos span, std::optional<ServiceId> by) {
  if (k.observer == nullptr) return;
  const bool mode = kind == SrEventKind::Mode;
  k.observer->on_sr_event(SrEvent{.kind = kind,
                                  .t = mode ? mode_changed_.t : k.now(),
                                  .wall = mode ? mode_changed_.wall : k.wall(),
                                  .epoch = k.kernel_clock.epoch(),
                                  .g = g,
                                  .mode = k.caps.mode(),
                                  .span = span,
                                  .by = by});
}

// ---- socket pairs made ahead ----

void Rejuvenator::refill_pairs() {
  const std::size_t want = static_cast<std::size_t>(
      std::count_if(k.services.begin(), k.services.end(),
                    [](const ServiceRuntime& s) { return s.config.rejuvenate && !s.config.skip; }));
  if (const auto shortage = channel_pool.refill(want))
    k.log("socket pairs made ahead: %s", shortage->to_string().c_str());
}

// A service's pagemap: opened by the kernel where it may (with root, or a service of its own uid), else by the
// agent in the service's user namespace (rejuv/sys/pagemap_agent.hpp), one per namespace: a cold restart
// makes a new namespace, and the agent of the old one goes.
sys::SysResult<sys::UniqueFd> Rejuvenator::open_pagemap(ServiceRuntime& s) {
  const pid_t pid = s.proc.process.pid();
  auto direct = sys::open_pagemap_without_frames(pid);
  if (direct || direct.error().error != EACCES || sys::running_as_root()) return direct;
  if (!s.pages.agent.serves(pid)) {
    s.pages.agent = {};
    auto agent = sys::PagemapAgent::start(pid);
    if (!agent) return std::unexpected(agent.error());
    s.pages.agent = std::move(*agent);
  }
  return s.pages.agent.open_pagemap(pid);
}

void Rejuvenator::open_pagemaps() {
  if (!k.options.images_by_pages) return;
  for (ServiceRuntime& s : k.services) {
    if (!s.config.rejuvenate || !s.live() || s.pages.base.value() == 0 || s.pages.pagemap.valid()) continue;
    if (auto opened = open_pagemap(s)) {
      s.pages.pagemap = std::move(*opened);
    } else if (!s.pages.pagemap_refusal_said) {
      // Without its pagemap a service's images are taken by fork: each costs time in proportion to its memory.
      s.pages.pagemap_refusal_said = true;
      k.log("images of '%s' by fork: %s", s.name.c_str(), opened.error().to_string().c_str());
    }
  }
}

// ---- retired generations ----

// The generation kept beyond K while the newest are not confirmed (ImageStore::trim) goes once they are: looked
// at every kTrimPeriod of wall time while there is one (a receive and a wait per copy), or at once (`now`).
void Rejuvenator::trim_images(bool now) {
  if (images_.size() <= images_.keep() || (!now && k.wall() < next_trim)) return;
  next_trim = k.wall() + kTrimPeriod;
  images_.refresh_all();
  for (image::GenerationRecord& r : images_.trim()) retire(std::move(r));
}

void Rejuvenator::retire(image::GenerationRecord record) {
  retiring_.push_back(std::move(record));
  finish_retiring(false);
}

void Rejuvenator::release_all_images() {
  if (std::optional<ImageWork> left = coordinator_.take_work()) {
    for (image::GenerationRecord& r : left->evicted) retiring_.push_back(std::move(r));
  }
  for (image::GenerationRecord& r : images_.take_all()) retiring_.push_back(std::move(r));
  finish_retiring(true);
  reaper_.kill_all_and_reap();
}

// A Patch on its way (a generation retired before its image was made: a fallback) comes from a copy of its
// base generation's image, kept or retiring: it may come while that image has a copy or is on its way.
bool Rejuvenator::patch_may_come(const image::Image& im) const {
  const image::GenerationRecord* base = images_.find(im.base);
  if (base == nullptr) {
    const auto retiring = std::find_if(retiring_.begin(), retiring_.end(),
                                       [&](const image::GenerationRecord& r) { return r.g == im.base; });
    base = retiring != retiring_.end() ? &*retiring : nullptr;
  }
  const image::Image* from = base != nullptr ? base->image_of(im.service) : nullptr;
  return from != nullptr && from->has_copy_or_patch();
}

bool Rejuvenator::take_unheard_copy(ServiceId service) {
  return unheard_.take(service, k.wall());
}

void Rejuvenator::finish_retiring(bool final) {
  const Nanos deadline = k.wall() + std::chrono::milliseconds{final ? 200 : 0};
  do {
    // Settled: no spare and no Patch still coming (patch_may_come), so that the copies they make are adopted
    // (refresh) and killed here rather than found by a sweep as strays. Every record is read before any is
    // let go: patch_may_come looks at the others. A spare or Patch asked of a copy that has died since (or
    // that was resumed: a fallback's) may still have been forked: it is left to the sweep as unheard_.
    std::vector<bool> settled;
    for (image::GenerationRecord& r : retiring_) {
      settled.push_back(std::all_of(r.images.begin(), r.images.end(), [](image::Image& im) {
        return !(im.refresh() > 0 && im.spares_pending > 0);
      }));
    }
    for (std::size_t i = 0; i < retiring_.size(); ++i) {
      const auto& images = retiring_[i].images;
      if (std::any_of(images.begin(), images.end(),
                      [&](const image::Image& im) { return im.patch_pending && patch_may_come(im); })) {
        settled[i] = false;
      }
    }
    std::size_t at = 0;
    std::erase_if(retiring_, [&](image::GenerationRecord& r) {
      if (!settled[at++]) return false;
      // Killed now (Reaper::kill) and reaped off the critical path (service_images).
      for (image::Image& im : r.images) {
        unheard_.let_go(im, k.wall());
        im.resume.close();
        for (sys::ChildProcess& c : im.copies) reaper_.kill(std::move(c));
      }
      return true;
    });
  } while (final && !retiring_.empty() && k.wall() < deadline);
  if (final) {
    for (image::GenerationRecord& r : retiring_) {
      for (const image::Image& im : r.images) unheard_.let_go(im, k.wall());
      image::destroy(r);
    }
    retiring_.clear();
  }
}

// Routing resumes after a cut, a restore or an abandoned checkpoint: what was published meanwhile was not
// pushed (docs/design.md §7). The kernel's held DDS bridge writes go out, then every live service's pending ring
// messages, in ring order.
void Rejuvenator::resume_routing() {
  routing_.thaw([&](ObjectId topic, std::span<const std::byte> payload) {
    return k.bridge && k.router.write_to_bridge(topic, payload);
  });
  for (ServiceRuntime& s : k.services) {
    if (!s.live()) continue;
    k.router.request_sweep(s);
    k.router.drain(s);
  }
}

// ---- safe points ----

void Rejuvenator::leave_image_work(ImageWork work) {
  coordinator_.leave_work(std::move(work), k.wall() + ImageCoordinator::kImageWorkWait);
  // Without a vehicle no control update comes: the work runs at once (benchmarks, tests of the image store).
  if (!k.graph.graph.has_plant()) run_image_work();
}

void Rejuvenator::image_work_if_due() {
  if (coordinator_.work_due(k.wall())) run_image_work();
}

void Rejuvenator::run_image_work() {
  std::optional<ImageWork> left = coordinator_.take_work();
  if (!left) return;
  ImageWork& work = *left;
  if (work.patches) {
    if (image::GenerationRecord* record = images_.find(*work.patches)) send_patches(*record);
  }
  for (image::GenerationRecord& old : work.evicted) retire(std::move(old));
  // In real time with a vehicle the sweep never waits for copies on their way (a service with one is swept
  // at the next safe point after it has reported, sweep_due); elsewhere, briefly, so that no stray outlives a
  // rollback.
  const bool vehicle_waits = k.clock_mode == ClockMode::Realtime && k.graph.graph.has_plant();
  if (!work.sweep.empty()) {
    k.warden.sweep_strays(work.sweep, false, vehicle_waits ? SweepWait::No : work.sweep_wait);
  }
  if (work.spares) {
    if (image::GenerationRecord* record = images_.find(*work.spares)) {
      for (image::Image& im : record->images) (void)im.request_spare(*work.spares);
    }
  }
  reaper_.kill_retired();
}

bool Rejuvenator::service_images() {
  image_work_if_due();
  // Incarnations retired by a rollback killed (with the image work: after the vehicle's next update), then the
  // killed ones reaped (Reaper::reap), all off the rollback's critical path. In this order: a SIGKILL's victim
  // runs its exit at once, so most are reaped here, not one safe point later (where `rejuv soak` found them as
  // one more process and fd at a sample).
  if (!coordinator_.work_left()) reaper_.kill_retired();
  if (!retiring_.empty()) finish_retiring(false);
  reaper_.reap();
  using enum ImageCoordinator::Checkpoint;
  if (!k.stopping && coordinator_.checkpoint() == None && !coordinator_.rollback_asked())
    k.warden.sweep_if_due();  // warden.cpp
  if (!k.sr || k.stopping || coordinator_.checkpoint() == Running) return false;
  if (!coordinator_.asked()) {  // off the critical paths
    refill_pairs();
    open_pagemaps();
    if (!coordinator_.work_left()) trim_images(false);
  }
  if (coordinator_.checkpoint() != Asked) fire_rejuvenation_early();
  if (coordinator_.rollback_asked()) {
    const std::string reason = coordinator_.take_rollback();
    settle_dying();
    run_rollback(reason);
    return true;
  }
  if (coordinator_.checkpoint() != Asked) {
    pace_.started();  // nothing waits (a rollback may have voided the request)
    return false;
  }
  // In real time with a vehicle, in the slack after a control update (vehicle_pace.hpp); never during an estimate
  // catch-up (its cut would fall inside the replay, with live samples still waiting behind it: catch_up.hpp).
  if (!catch_up_.replaying() && quiescent_for_checkpoint() && pace_.may_start(k.wall())) {
    pace_.started();
    settle_dying();
    run_checkpoint();
    return true;
  }
  return false;
}

Nanos Rejuvenator::wait_bound(Nanos seen, Nanos unseen) const {
  return image_charge_.vehicle_sees_work() ? seen : unseen;
}

Nanos Rejuvenator::image_wait_bound() const {
  return wait_bound(k.options.resume_deadline, k.options.unseen_resume_deadline);
}

// Backpressure before a checkpoint or a rollback, which both need new processes (images, spares): the killed
// ones hold their uid's process slots (max_processes, RLIMIT_NPROC) until reaped, and on a loaded machine
// they die slowly — every process of a service shares its session's CPU share. Without this, 1000 SR cycles
// in 2 s of wall time on 2 cores shared with six other multiproc tests left a copy unable to fork (the
// generation then unusable). Waits, within image_wait_bound(), until few enough are dying (processes_to_spare).
void Rejuvenator::settle_dying() {
  reaper_.settle(k.wall() + image_wait_bound());
}

// What every rejuvenated service can spare: half of what its max_processes leaves beside 1 + 2(K + 1), the
// live one and an image and a spare per generation (no limit: any number).
std::uint64_t Rejuvenator::processes_to_spare() const {
  std::uint64_t least = std::numeric_limits<std::uint64_t>::max();
  const std::uint64_t needed = 1 + 2 * (std::uint64_t{launch::keep_generations(k.graph.graph.sr())} + 1);
  for (const ServiceRuntime& s : k.services) {
    if (!s.config.rejuvenate || s.config.skip) continue;
    if (const auto limit = k.warden.limits_for(s).processes)
      least = std::min(least, *limit > needed ? *limit - needed : 0);
  }
  return least == std::numeric_limits<std::uint64_t>::max() ? least : least / 2;
}

Result<void, KernelError> Rejuvenator::finish_image_requests() {
  while (!k.stopping && coordinator_.asked()) {
    if (service_images()) continue;
    if (auto ok = k.pump(std::chrono::milliseconds{100}); !ok) return ok;
  }
  return {};
}

// ---- the rejuvenation timer ----

void Rejuvenator::arm_rejuvenation(ServiceRuntime& s, std::uint32_t seq, Nanos after, Nanos period) {
  const Epoch epoch = k.kernel_clock.epoch();
  if (coordinator_.armed_in(epoch)) {
    // docs/design.md §7: at most one arm per epoch, so the recursive do_timer of §V-C (Fig. 8) cannot happen.
    ++sr_stats_.timer_arm_refused;
    k.log("'%s' armed the rejuvenation timer a second time in epoch %u: refused", s.name.c_str(),
          epoch.value());
    sr_event(SrEventKind::TimerRefused, {}, after, s.id);
    k.input.reply(s, seq, op_code(wire::OpError::Refused));
    return;
  }
  if (after <= Nanos{0} || period < Nanos{0}) {
    k.input.reply(s, seq, op_code(wire::OpError::BadArgument));
    return;
  }
  coordinator_.arm_timer(epoch, k.now() + after, period);
  ++sr_stats_.timer_arms;
  sr_event(SrEventKind::TimerArmed, {}, after, s.id);
  k.arm_timerfd();
  k.input.reply(s, seq, 0, static_cast<std::uint64_t>(coordinator_.timer_due()->count()));
}

// In real time with a vehicle: a timer due before the next control update fires now, in the slack after this
// one (vehicle_pace.hpp) — up to one period early, never late — so that the rollback does not run across the
// next sample's update. The next safe point carries it out.
void Rejuvenator::fire_rejuvenation_early() {
  const std::optional<Nanos> due = coordinator_.timer_due();
  if (!due || coordinator_.rollback_asked() || !pace_.fire_early(k.wall(), *due - k.now())) return;
  coordinator_.timer_fired();
  ++sr_stats_.timer_rollbacks;
  request_rollback("the rejuvenation timer fired (in the slack before it was due)");
}

void Rejuvenator::fire_rejuvenation() {
  const std::optional<Nanos> due = coordinator_.timer_due();
  if (!due || *due > k.now()) return;
  coordinator_.timer_fired();
  ++sr_stats_.timer_rollbacks;
  request_rollback("the rejuvenation timer fired");
}

}  // namespace rejuv::kernel
