// Checkpoint and rollback of the rejuvenated services with the queue state beside them (DESIGN §7; the
// paper's §V create_checkpoint / rollback, which took ≈20 ms and ≈15 ms in the PX4 kernel module).
//
// Checkpoint g (the caller — checkpoint_p in CP — invoked CheckpointCreate and waits for its Reply):
//   1. At a quiescent point (lockstep: every other service idle; every channel drained) routing freezes:
//      publications still land in the rings but nothing is delivered, so no service reads past the cut.
//   2. Every live rejuvenated service gets Snapshot{g, base} with a fresh resume socket. Where it can, it
//      copies the pages written since `base` into a sealed memfd and answers TakenPages (after the commit a
//      copy of base's image makes g's from them: send_patches); otherwise it forks its image (the kernel's
//      child, clone(CLONE_PARENT)) and answers Taken{g, pid}. The caller takes its image inside its call.
//   3. Publications that arrive before their sender's Taken belong before the cut: they are applied to the
//      rings, undelivered. Then the rings, generations, cursors, each service's subscriptions and timers and
//      t_cp are saved beside the images; the oldest generation beyond K is discarded; the caller gets its
//      Reply (Taken in the live process); routing resumes.
// Rollback (the rejuvenation timer, a CheckpointRollback, a rejuvenated service lost):
//   1. Mode RB (network revoked). Every live rejuvenated service is cut off (its channel out of the loop,
//      closed after the timed part) and set to SCHED_IDLE; it is killed once the rollback is over.
//   2. Each image of the newest intact generation gets Resume{g, epoch} with a new channel; the frozen copy
//      that reads it answers Resumed{g, its pid} on the new channel; a Fork afterwards makes a new spare.
//   3. The queue state and kernel objects are restored (periodic and one-shot timers shifted by now − t_cp);
//      rollback_signal and sr_mode are published; routing resumes. Driver-level services (output_driver) are
//      never touched: the broker re-bases their cursors to the restored head.
// Faults: a refused or late Taken abandons the generation (a late service is killed, which is itself a
// rollback trigger); a dead image or a failed resume falls back to the previous generation, then to a cold
// restart of the rejuvenated services from their binaries in SC (network off). Every path is logged.
#include <fcntl.h>

#include <algorithm>
#include <limits>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <utility>

#include "impl.hpp"

namespace rejuv::kernel {

namespace {

double to_ms(Nanos d) { return static_cast<double>(d.count()) / 1e6; }
unsigned long long num(Generation g) { return static_cast<unsigned long long>(g.value()); }

}  // namespace

std::optional<ObjectId> Kernel::Impl::kernel_topic(std::string_view type) const {
  for (const ObjectInfo& o : objects) {
    if (o.type != nullptr && o.type->name == type && o.kernel == policy::KernelEndpoint::Publishes) return o.id;
  }
  return std::nullopt;
}

void Kernel::Impl::set_mode(SrMode mode, std::optional<ServiceId> by) {
  if (auto changed = caps.apply_mode(mode); !changed) {
    log("mode %s: %s", std::string(to_string(mode)).c_str(), std::string(cap::to_string(changed.error())).c_str());
    return;
  }
  time_page.write(clock::TimeSample{.now = now(), .mode = mode, .epoch = time_page.current().epoch});
  publish_sr_mode();
  sr_event(SrEventKind::Mode, {}, {}, by);
}

void Kernel::Impl::sr_event(SrEventKind kind, Generation g, Nanos span, std::optional<ServiceId> by) {
  if (observer == nullptr) return;
  observer->on_sr_event(SrEvent{.kind = kind, .t = now(), .wall = wall(), .epoch = time_page.current().epoch,
                                .g = g, .mode = caps.mode(), .span = span, .by = by});
}

// ---- socket pairs made ahead ----

std::optional<std::pair<sys::SeqPacket, sys::SeqPacket>> Kernel::Impl::take_pair() {
  if (!pair_pool.empty()) {
    auto pair = std::move(pair_pool.back());
    pair_pool.pop_back();
    return pair;
  }
  auto pair = sys::SeqPacket::pair(sys::Blocking::Yes);
  if (!pair) {
    // Out of fds or memory (EMFILE, ENFILE, ENOMEM): said, never silent; the caller abandons or falls back.
    log("a channel for a checkpoint or rollback: %s", pair.error().to_string().c_str());
    return std::nullopt;
  }
  if (auto ok = sys::set_nonblocking(pair->first.fd(), true); !ok) {
    log("a channel for a checkpoint or rollback: %s", ok.error().to_string().c_str());
    return std::nullopt;
  }
  return std::move(*pair);
}

void Kernel::Impl::refill_pairs() {
  closing.clear();
  // One checkpoint or one rollback of every rejuvenated service.
  const std::size_t want = static_cast<std::size_t>(
      std::count_if(services.begin(), services.end(), [](const ServiceRuntime& s) { return s.rejuvenate && !s.skip; }));
  while (pair_pool.size() < want) {
    auto pair = sys::SeqPacket::pair(sys::Blocking::Yes);
    if (!pair) {
      if (!pair_shortage_logged) log("socket pairs made ahead: %s", pair.error().to_string().c_str());
      pair_shortage_logged = true;
      return;
    }
    if (!sys::set_nonblocking(pair->first.fd(), true)) return;
    pair_shortage_logged = false;
    pair_pool.push_back(std::move(*pair));
  }
}

void Kernel::Impl::open_pagemaps() {
  if (!options.images_by_pages) return;
  for (ServiceRuntime& s : services) {
    if (!s.rejuvenate || !s.live() || s.image_base.value() == 0 || s.pagemap.valid()) continue;
    const std::string path = "/proc/" + std::to_string(s.process.pid()) + "/pagemap";
    s.pagemap = sys::UniqueFd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  }
}

// ---- retired generations ----

void Kernel::Impl::retire(image::GenerationRecord record) {
  retiring.push_back(std::move(record));
  finish_retiring(false);
}

void Kernel::Impl::finish_retiring(bool final) {
  const Nanos deadline = wall() + std::chrono::milliseconds{final ? 200 : 0};
  do {
    std::erase_if(retiring, [&](image::GenerationRecord& r) {
      bool settled = true;
      for (image::Image& im : r.images) {
        if (im.refresh() > 0 && im.spares_pending > 0) settled = false;
      }
      if (!settled) return false;
      for (image::Image& im : r.images) {  // killed now, reaped off the critical path (service_images)
        im.resume.close();
        for (sys::ChildProcess& c : im.copies) {
          (void)sys::lower_priority(c.pid());
          (void)c.signal(SIGKILL);
          reaping.push_back(std::move(c));
        }
      }
      return true;
    });
  } while (final && !retiring.empty() && wall() < deadline);
  if (final) {
    for (image::GenerationRecord& r : retiring) image::destroy(r);
    retiring.clear();
  }
}

// Routing resumes after a cut, a restore or an abandoned checkpoint: what was published meanwhile was not
// pushed (DESIGN §7). The kernel's held DDS bridge writes go out, then every live service's pending ring
// messages, in ring order.
void Kernel::Impl::resume_routing() {
  routing_frozen = false;
  release_bridge_out();
  for (ServiceRuntime& s : services) {
    if (!s.live()) continue;
    s.sweep = true;
    drain(s);
  }
}

// ---- safe points ----

bool Kernel::Impl::service_images() {
  // Killed ones reaped (reap_dying); then incarnations retired by a rollback are killed, all off the
  // rollback's critical path.
  reap_dying();
  kill_retired();
  if (!retiring.empty()) finish_retiring(false);
  if (!stopping && !checkpoint && !rollback_request && !checkpoint_request) sweep_if_due();  // sandbox.cpp
  if (!sr || stopping || checkpoint) return false;
  if (!rollback_request && !checkpoint_request) {  // off the critical paths
    refill_pairs();
    open_pagemaps();
  }
  if (rollback_request) {
    const std::string reason = std::move(*rollback_request);
    rollback_request.reset();
    settle_dying();
    run_rollback(reason);
    return true;
  }
  if (checkpoint_request && quiescent_for_checkpoint()) {
    settle_dying();
    run_checkpoint();
    return true;
  }
  return false;
}

Nanos Kernel::Impl::image_wait_bound() const {
  const bool seen = clock_mode != ClockMode::Lockstep || options.charge == KernelOptions::Charge::Measured;
  return seen ? options.resume_deadline : options.unseen_resume_deadline;
}

// Backpressure before a checkpoint or a rollback, which both need new processes (images, spares): the killed
// ones hold their uid's process slots (max_processes, RLIMIT_NPROC) until reaped, and on a loaded machine
// they die slowly — every process of a service shares its session's CPU share. Without this, 1000 SR cycles
// in 2 s of wall time on 2 cores shared with six other multiproc tests left a copy unable to fork (the
// generation then unusable). Waits, within image_wait_bound(), until at most as many are dying as every
// rejuvenated service can spare: half of what its max_processes leaves beside 1 + 2(K + 1).
void Kernel::Impl::settle_dying() {
  const auto slack = [&] {
    std::uint64_t least = std::numeric_limits<std::uint64_t>::max();
    const std::uint64_t needed = 1 + 2 * (std::uint64_t{launch::keep_generations(graph.graph.sr())} + 1);
    for (const ServiceRuntime& s : services) {
      if (!s.rejuvenate || s.skip) continue;
      if (const auto limit = limits_for(s).processes) least = std::min(least, *limit > needed ? *limit - needed : 0);
    }
    return least == std::numeric_limits<std::uint64_t>::max() ? least : least / 2;
  }();
  reap_dying();
  const Nanos until = wall() + image_wait_bound();
  while (reaping.size() > slack && wall() < until) {
    (void)sys::wait_fd(reaping.front().pidfd(), sys::WaitFor::Readable, until - wall());
    reap_dying();
  }
}

// Killed processes reaped; one still dying gets back its normal priority. It was lowered so that its exit
// would not take the CPU from a checkpoint or rollback; this runs at a safe point after it. Left low, on a
// loaded machine a process killed at idle priority took seconds to die, and the dying held their uid's
// process slots: 60 of the worker's 64 in Images.HundredRollbacks on 2 cores shared with six multiproc
// tests, where its next resumed image could not start its thread.
void Kernel::Impl::reap_dying() {
  std::erase_if(reaping, [](sys::ChildProcess& p) {
    auto status = p.try_wait();
    if (status && !*status) (void)sys::normal_priority(p.pid());
    return !status || *status;
  });
}

bool Kernel::Impl::quiescent_for_checkpoint() const {
  const std::optional<ServiceId> caller = checkpoint_request->first;
  return std::all_of(services.begin(), services.end(), [&](const ServiceRuntime& s) {
    if (!s.live()) return true;
    if (s.phase != Phase::Ready || !s.drained()) return false;
    return clock_mode == ClockMode::Realtime || s.id == caller || s.idle();
  });
}

// ---- checkpoint ----

bool Kernel::Impl::lost_during(CheckpointRun& run) const {
  // A service of the checkpoint that died before the commit — before its Taken (it will never answer) or after
  // it — has left the broker and the timer table (on_child_exit): the generation would lack its kernel objects
  // and an image restored from it would receive nothing (the fault campaign: ekf2 killed right after its Taken,
  // restored deaf, the vehicle lost). Not a generation.
  if (!run.failure.empty()) return true;
  for (const image::Image& im : run.record.images) {
    const ServiceRuntime& s = services[im.service.value()];
    if (!s.live()) {
      run.failure = "'" + s.name + "' was lost during the checkpoint";
      return true;
    }
  }
  return false;
}

void Kernel::Impl::run_checkpoint() {
  const auto [caller, seq] = *checkpoint_request;
  checkpoint_request.reset();
  const bool priming = std::exchange(priming_request, false);
  const Nanos t0 = wall();
  const Generation g = images.next_generation();
  CheckpointRun run{.caller = caller, .seq = seq, .record = {}, .waiting = {}, .failure = {}};
  run.record.g = g;
  run.record.t_cp = now();
  routing_frozen = true;
  flush_staged();  // the round's publications so far: before the cut, into the rings, undelivered
  for (ServiceRuntime& s : services) {
    if (!s.rejuvenate || s.phase != Phase::Ready) continue;
    auto pair = take_pair();
    if (!pair) {
      run.failure = "resume socket: out of fds?";
      break;
    }
    const Generation base = pages_base_for(s);
    // The pagemap goes with the first Snapshot that offers a base to this incarnation; the service keeps it.
    const bool with_pagemap = base.value() != 0 && !s.pagemap_sent;
    const std::array<int, 2> fds{pair->second.fd(), s.pagemap.get()};
    const wire::SnapshotBody body{.base = base.value()};
    if (!tx.build_with(wire::FrameKind::Snapshot, 0, 0, g.value(), body)) break;
    if (auto sent = s.channel.send(tx.bytes(), std::span(fds).first(with_pagemap ? 2 : 1)); !sent) {
      run.failure = "Snapshot to '" + s.name + "': " + sent.error().to_string();
      break;
    }
    ++s.stats.frames_out;
    if (with_pagemap) s.pagemap_sent = true;
    // The image end stays with the kernel until the commit: by fork it is closed, by written pages it goes
    // to the copy of the base that becomes the image (send_patches).
    run.record.images.push_back(image::Image{.service = s.id, .copies = {}, .resume = std::move(pair->first),
                                             .base = base, .image_end = pair->second.take_fd()});
    run.waiting.push_back(s.id);
  }
  checkpoint = std::move(run);
  const Nanos t_sent = wall();
  if (observer != nullptr) observer->on_image_phase(ImagePhase::CheckpointSnapshotsSent, g);
  // Every other event is handled meanwhile (pump); Taken frames come through handle_frame → on_taken,
  // TakenPages (with its fd) through read_channel → on_taken_pages.
  const Nanos deadline = wall() + options.snapshot_deadline;
  bool late = false;
  while (checkpoint->failure.empty() && !checkpoint->waiting.empty() && !stopping) {
    if (lost_during(*checkpoint)) break;  // abandoned now rather than at the deadline
    const Nanos left = deadline - wall();
    if (left <= Nanos{0}) {
      late = true;
      checkpoint->failure = "no Taken from '" + services[checkpoint->waiting.front().value()].name +
                            "' within the snapshot deadline";
      break;
    }
    if (!pump(left)) break;
  }
  CheckpointRun done = std::move(*checkpoint);
  checkpoint.reset();
  if (done.failure.empty() && !done.waiting.empty()) done.failure = "the run is stopping";
  (void)lost_during(done);  // a death read in the last pump
  const auto answer = [&](std::int32_t error, std::uint64_t value) {
    if (caller) reply(services[caller->value()], seq, error, value);
  };
  if (!done.failure.empty()) {
    if (!priming) ++sr_stats.checkpoint_failures;
    if (!priming) sr_event(SrEventKind::CheckpointFailed, g, wall() - t0, caller);
    log("%s %llu abandoned: %s", priming ? "the alignment's checkpoint" : "checkpoint", num(g), done.failure.c_str());
    abandoned = Abandoned{.g = g, .waiting = done.waiting};
    images.abandon(g);
    image::destroy(done.record);
    if (late) {
      for (const ServiceId id : done.waiting) kill_hung(services[id.value()], "no Taken within the snapshot deadline");
    }
    resume_routing();
    answer(op_code(wire::OpError::Refused), 0);
    return;
  }
  const Nanos t_taken = wall();
  if (observer != nullptr) observer->on_image_phase(ImagePhase::CheckpointTaken, g);
  flush_staged();  // publications that reached the kernel before their sender's Taken: before the cut
  const std::vector<clock::KernelTimer> armed = timers.armed();
  for (const image::Image& im : done.record.images) {
    image::SavedService saved{.service = im.service, .subscriptions = services[im.service.value()].subscriptions,
                              .timers = {}};
    for (const clock::KernelTimer& t : armed) {
      if (t.service == im.service) saved.timers.push_back(t);
    }
    done.record.services.push_back(std::move(saved));
  }
  broker.snapshot_into(done.record.queues);
  if (observer != nullptr) observer->on_checkpoint(g, broker);
  for (const image::Image& im : done.record.images) services[im.service.value()].image_base = g;
  std::vector<image::GenerationRecord> evicted = images.commit(std::move(done.record));
  const Nanos t_saved = wall();  // committed: the caller may go on (what follows is not on its path)
  resume_routing();
  answer(0, g.value());
  const std::uint64_t forks_before = sr_stats.images_by_fork;
  send_patches(*images.newest());  // before old generations go: a base may be among them
  for (image::GenerationRecord& old : evicted) retire(std::move(old));
  const Nanos took = t_saved - t0;
  // Strays (sandbox.cpp): after the timed part, before the new spares are on their way, so that only the
  // copies still on their way from earlier requests can defer it.
  abandoned.reset();  // an image still owed to an abandoned checkpoint is a stray from now on
  sweep_strays("a checkpoint's commit");
  for (image::Image& im : images.newest()->images) (void)im.request_spare(g);  // the spare copies, async
  if (priming) {
    // DESIGN §6: the alignment's images, by fork, are not part of the flight: neither counted nor charged.
    sr_stats.priming_images += sr_stats.images_by_fork - forks_before;
    sr_stats.images_by_fork = forks_before;
    log("the alignment's checkpoint: %zu images by fork in %.3f ms (untimed, not charged)",
        images.newest()->images.size(), to_ms(took));
    return;
  }
  sr_stats.checkpoint_phases.a.add(to_ms(t_sent - t0));
  sr_stats.checkpoint_phases.b.add(to_ms(t_taken - t_sent));
  sr_stats.checkpoint_phases.c.add(to_ms(t_saved - t_taken));
  ++sr_stats.checkpoints;
  sr_event(SrEventKind::Checkpoint, g, took, caller);
  sr_stats.checkpoint_ms.add(to_ms(took));
  if (!sr_stats.first_checkpoint_ms) sr_stats.first_checkpoint_ms = to_ms(took);
  charge_image_work(took, checkpoint_charge);
  if (options.verbose) log("checkpoint %llu: %zu images in %.3f ms", num(g), images.newest()->images.size(), to_ms(took));
}

bool Kernel::Impl::late_image(ServiceRuntime& s, const wire::FrameView& frame) {
  if (!abandoned || frame.header.aux != abandoned->g.value()) return false;
  const auto waiting = std::find(abandoned->waiting.begin(), abandoned->waiting.end(), s.id);
  if (waiting == abandoned->waiting.end()) return false;
  abandoned->waiting.erase(waiting);
  // TakenPages: its pages fd closes with the frame. Taken: the image is a process of the service's session
  // that the kernel made it fork and no longer wants. Anything else the pid could name is left alone.
  if (frame.kind != wire::FrameKind::Taken) return true;
  const pid_t pid = wire::payload_as<wire::TakenBody>(frame).image_pid;
  if (pid <= 0 || knows_process(pid, nullptr)) return true;
  const auto sid = sys::session_of(pid);
  if (sid && std::find(s.sessions.begin(), s.sessions.end(), *sid) != s.sessions.end()) {
    (void)sys::kill_and_reap_own_child(pid);
  }
  return true;
}

// DESIGN §6: the simulated time a checkpoint or rollback costs the plant's world (controls held) is the launch
// file's model by default, so that a lockstep run is deterministic; its real duration only with --charge
// measured. Realtime: the world went on by itself; nothing to charge.
void Kernel::Impl::charge_image_work(Nanos measured, Nanos modelled) {
  sr_stats.measured += measured;
  if (clock_mode != ClockMode::Lockstep) return;
  const Nanos charged = options.charge == KernelOptions::Charge::Model ? modelled : measured;
  charge += charged;
  sr_stats.charged += charged;
}

bool Kernel::Impl::expecting_image(ServiceRuntime& s, const wire::FrameView& frame) {
  if (late_image(s, frame)) return false;  // the answer of an abandoned checkpoint: not a protocol error
  if (!checkpoint) {
    refuse(s, std::string(wire::to_string(frame.kind)) + " without a checkpoint in progress");
    return false;
  }
  CheckpointRun& run = *checkpoint;
  const auto waiting = std::find(run.waiting.begin(), run.waiting.end(), s.id);
  if (waiting == run.waiting.end()) {
    refuse(s, std::string(wire::to_string(frame.kind)) + " it was not asked for");
    return false;
  }
  run.waiting.erase(waiting);
  if (frame.header.aux != run.record.g.value()) {
    run.failure = "'" + s.name + "' answered " + std::string(wire::to_string(frame.kind)) + " for generation " +
                  std::to_string(frame.header.aux);
    return false;
  }
  return true;
}

Generation Kernel::Impl::pages_base_for(const ServiceRuntime& s) {
  const Generation base = s.image_base;
  if (!options.images_by_pages || base.value() == 0 || images.keep() < 2) return Generation{};
  if (!s.pagemap.valid()) return Generation{};
  // The base must outlive this checkpoint's commit, which keeps the newest keep − 1 generations and the new one.
  const std::vector<Generation> kept = images.generations();
  const std::size_t survivors = std::min(kept.size(), images.keep() - 1);
  if (std::find(kept.end() - static_cast<std::ptrdiff_t>(survivors), kept.end(), base) == kept.end()) return Generation{};
  image::GenerationRecord* record = images.find(base);
  image::Image* im = record != nullptr ? record->image_of(s.id) : nullptr;
  // No refresh() here (a receive and a wait per copy, on the critical path): a copy that died since is found
  // when the Patch goes unanswered, and a rollback to this generation falls back (dead_image).
  if (im == nullptr || !im->has_copy_or_patch()) return Generation{};
  return base;
}

void Kernel::Impl::on_taken_pages(ServiceRuntime& s, const wire::FrameView& frame, sys::UniqueFd pages) {
  if (!expecting_image(s, frame)) return;
  CheckpointRun& run = *checkpoint;
  image::Image* im = run.record.image_of(s.id);
  const auto body = wire::payload_as<wire::TakenPagesBody>(frame);
  // What the service may not choose: the base (the one offered), and pages that change after this answer
  // (every seal that freezes the memfd's contents).
  const int seals = ::fcntl(pages.get(), F_GET_SEALS);
  if (im == nullptr || im->base.value() == 0 || body.base != im->base.value()) {
    run.failure = "'" + s.name + "' took its image against generation " + std::to_string(body.base) +
                  ", which was not offered";
  } else if (seals < 0 || (seals & wire::kPagesSeals) != wire::kPagesSeals) {
    run.failure = "'" + s.name + "' sent written pages that are not sealed";
  } else if (body.pages > wire::kMaxImagePages) {
    run.failure = "'" + s.name + "' sent " + std::to_string(body.pages) + " written pages (at most " +
                  std::to_string(wire::kMaxImagePages) + ")";
  } else {
    im->pages = std::move(pages);
    im->page_count = body.pages;
  }
}

void Kernel::Impl::send_patches(image::GenerationRecord& record) {
  for (image::Image& im : record.images) {
    if (!im.pages.valid()) {  // by fork: the image is its own process
      ++sr_stats.images_by_fork;
      closing.push_back(std::move(im.image_end));
      continue;
    }
    ++sr_stats.images_by_pages;
    image::GenerationRecord* base = images.find(im.base);
    image::Image* from = base != nullptr ? base->image_of(im.service) : nullptr;
    const wire::PatchBody body{.generation = record.g.value(), .pages = im.page_count};
    const std::array<int, 2> fds{im.pages.get(), im.image_end.get()};
    if (from != nullptr && tx.build_with(wire::FrameKind::Patch, 0, 0, im.base.value(), body) &&
        from->resume.send(tx.bytes(), fds)) {
      im.patch_pending = true;
    } else {  // no image: a rollback to this generation falls back (image::GenerationRecord::dead_image)
      log("generation %llu: no copy of generation %llu's image of '%s' to make its image from",
          num(record.g), num(im.base), services[im.service.value()].name.c_str());
    }
    closing.push_back(std::move(im.pages));
    closing.push_back(std::move(im.image_end));
  }
}

bool Kernel::Impl::knows_process(pid_t pid, const image::GenerationRecord* taking) const {
  const auto in = [&](const image::GenerationRecord& r) {
    return std::any_of(r.images.begin(), r.images.end(), [&](const image::Image& i) {
      return std::any_of(i.copies.begin(), i.copies.end(), [&](const sys::ChildProcess& c) { return c.pid() == pid; });
    });
  };
  return images.owns(pid) || (plant_started && plant.pid() == pid) ||
         std::any_of(services.begin(), services.end(), [&](const ServiceRuntime& o) { return o.process.pid() == pid; }) ||
         (taking != nullptr && in(*taking));
}

void Kernel::Impl::on_taken(ServiceRuntime& s, const wire::FrameView& frame) {
  if (!expecting_image(s, frame)) return;
  CheckpointRun& run = *checkpoint;
  const pid_t pid = wire::payload_as<wire::TakenBody>(frame).image_pid;
  if (pid <= 0) {
    run.failure = "'" + s.name + "' could not take its image";
    return;
  }
  // The pid must be the kernel's child and no process the kernel already knows: a service cannot make the
  // kernel take charge of (and later kill) anything but its own image.
  const bool known = knows_process(pid, &run.record);
  auto child = known ? sys::SysResult<sys::ChildProcess>(std::unexpected(sys::SysError{"known pid", EEXIST}))
                     : sys::ChildProcess::adopt_child(pid);
  if (!child && sys::out_of_fds(child.error().error)) {
    // The kernel is out of fds (keep_generations against ulimit -n): the image cannot be kept. It is the
    // kernel's own copy, not the service's stray: killed now, so that no sweep counts it as a violation.
    (void)sys::kill_and_reap_own_child(pid);
    run.failure = "no fd left to keep the image of '" + s.name + "' (" + child.error().to_string() +
                  "): raise ulimit -n or lower keep_generations";
    return;
  }
  if (!child) {
    run.failure = "'" + s.name + "' reported pid " + std::to_string(pid) + ", which is not its image (" +
                  child.error().to_string() + ")";
    return;
  }
  run.record.image_of(s.id)->copies.push_back(std::move(*child));
}

// ---- rollback ----

void Kernel::Impl::request_rollback(std::string reason) {
  if (!rollback_request) rollback_request = std::move(reason);
}

void Kernel::Impl::kill_retired() {
  for (sys::ChildProcess& p : retired) {
    (void)p.signal(SIGKILL);
    reaping.push_back(std::move(p));
  }
  retired.clear();
}

void Kernel::Impl::retire_live_rejuvenated() {
  std::erase_if(staged, [&](const Staged& e) { return services[e.origin].rejuvenate; });
  for (ServiceRuntime& s : services) {
    if (!s.rejuvenate || s.skip || s.phase == Phase::NotStarted) continue;
    if (s.live()) {
      // Not signalled here: a signal wakes its victim, which then takes the CPU at once (8 SIGKILLs 0.68 ms:
      // its exit runs inline; 8 SIGSTOPs 0.09 ms; 8 switches to SCHED_IDLE 0.013 ms; /tmp micro-benchmark,
      // one CPU). Under SCHED_IDLE it runs only when nothing else on its CPU can, with its channel out of
      // the loop, no signal to another process and no socket (seccomp): it cannot slow the rollback down or
      // reach anything. Where the switch is refused, it is stopped. Killed after the rollback (kill_retired).
      if (!sys::idle_priority(s.process.pid())) (void)s.process.signal(SIGSTOP);
      (void)epoll.remove(s.process.pidfd());
      retired.push_back(std::move(s.process));
      s.process = sys::ChildProcess{};
    }
    if (s.channel.valid()) {
      (void)epoll.remove(s.channel.fd());
      closing.push_back(s.channel.take_fd());  // closed off the critical path (refill_pairs)
    }
    s.phase = Phase::Dead;
    broker.remove_service(s.id);
    timers.remove_service(s.id);
    s.outq.clear();
    s.has_held = false;
    s.want_writable = false;
    s.sweep = false;
    s.polled_pending = false;
    s.control_pool.clear();
    s.control_free.clear();
    s.channel_closed_at.reset();
    s.loss_reason.clear();
  }
}

namespace {
// The first frame on a restored image's new channel: Resumed{g, its pid}; otherwise why not (a hang-up, no
// frame before `deadline`, another frame), with the wall time waited.
std::expected<pid_t, std::string> read_resumed(const sys::SeqPacket& channel, Generation g, Nanos deadline) {
  const Nanos start = sys::monotonic_now();
  const auto waited = [&] { return std::to_string(to_ms(sys::monotonic_now() - start)) + " ms"; };
  auto ready = sys::wait_fd(channel.fd(), sys::WaitFor::Readable, std::max(Nanos{0}, deadline - start));
  if (!ready) return std::unexpected("waiting: " + ready.error().to_string());
  if (!*ready) return std::unexpected("no answer in " + waited());
  std::array<std::byte, sizeof(wire::FrameHeader) + sizeof(wire::TakenBody)> buf{};
  auto got = channel.receive(buf);
  if (!got) return std::unexpected("reading: " + got.error().to_string());
  if (got->closed) return std::unexpected("its channel hung up after " + waited());
  auto frame = wire::decode(std::span<const std::byte>(buf.data(), got->size), wire::Direction::ToKernel);
  if (!frame) return std::unexpected("an undecodable answer");
  if (frame->kind != wire::FrameKind::Resumed || frame->header.aux != g.value()) {
    return std::unexpected(std::string(wire::to_string(frame->kind)) + " for generation " +
                           std::to_string(frame->header.aux) + " instead of Resumed");
  }
  return wire::payload_as<wire::TakenBody>(*frame).image_pid;
}
}  // namespace

bool Kernel::Impl::resume_generation(image::GenerationRecord& record, Nanos deadline, std::string& failure,
                                     Nanos& resumed_at) {
  const Epoch next{time_page.current().epoch.value() + 1};
  struct Pending {
    ServiceRuntime* service = nullptr;
    image::Image* image = nullptr;
    sys::SeqPacket channel{};  // the kernel's end of the new channel
  };
  std::vector<Pending> pending;
  pending.reserve(record.images.size());
  // All Resumes first: the images wake in parallel. No fork here: a spare copy takes the Resume.
  for (image::Image& im : record.images) {
    ServiceRuntime& s = services[im.service.value()];
    auto channel = take_pair();
    if (!channel) {
      failure = "channel for a restored image: out of fds?";
      break;
    }
    const wire::ResumeBody body{.epoch = next.value(), .reserved = 0};
    if (!tx.build_with(wire::FrameKind::Resume, 0, 0, record.g.value(), body)) break;
    const int service_end = channel->second.fd();
    if (auto sent = im.resume.send(tx.bytes(), std::span(&service_end, 1)); !sent) {
      failure = "Resume to the image of '" + s.name + "': " + sent.error().to_string();
      break;
    }
    // Closed now, not after the timed part: then the image's end is the channel's only other end, and a copy
    // that dies after taking its Resume hangs the channel up at once instead of costing the resume deadline.
    (void)channel->second.take_fd();
    pending.push_back(Pending{.service = &s, .image = &im, .channel = std::move(channel->first)});
  }
  if (observer != nullptr) observer->on_image_phase(ImagePhase::RollbackResumesSent, record.g);
  // Then every Resumed; each restored incarnation is installed as the live service as soon as it answers
  // (on a failure the caller retires it again).
  for (Pending& p : pending) {
    ServiceRuntime& s = *p.service;
    const auto answer = read_resumed(p.channel, record.g, deadline);
    const pid_t pid = answer.value_or(0);
    auto copy = std::find_if(p.image->copies.begin(), p.image->copies.end(),
                             [&](const sys::ChildProcess& c) { return pid > 0 && c.pid() == pid; });
    if (copy != p.image->copies.end()) {
      s.process = std::move(*copy);  // the copy is now the live service
      p.image->copies.erase(copy);
    } else if (auto spare = pid > 0 ? sys::ChildProcess::adopt_child(pid)
                                    : sys::SysResult<sys::ChildProcess>(std::unexpected(sys::SysError{"Resumed", EPROTO}))) {
      s.process = std::move(*spare);  // a spare whose Copied is still on its way took the Resume
    } else {
      if (failure.empty()) {
        const image::Image& im = *p.image;
        failure = "no Resumed from the image of '" + s.name + "': " +
                  (answer ? "pid " + std::to_string(pid) + " is no copy" : answer.error()) + " (" +
                  std::to_string(im.copies.size()) + " copies, " + std::to_string(im.spares_pending) + " spares and " +
                  (im.patch_pending ? "its patch" : "no patch") + " on their way" +
                  (im.last_death.empty() ? "" : "; " + im.last_death) + ")";
      }
      continue;  // its copies are killed with the generation
    }
    p.image->resumed.push_back(pid);
    s.start_incarnation(record.g);
    s.channel = std::move(p.channel);
    s.phase = Phase::Ready;
    s.frames_base = s.stats.frames_out;
    s.idle_count = 0;
    s.stats.pid = s.process.pid();
    // A restored incarnation the loop does not watch would die unnoticed (no rollback, no restart): the
    // generation is unusable rather than half-installed.
    for (const auto& [fd, source] : {std::pair{s.channel.fd(), Source::Channel}, std::pair{s.process.pidfd(), Source::Pidfd}}) {
      if (auto added = epoll.add(fd, token(source, s.id.value())); !added && failure.empty()) {
        failure = "watching the restored '" + s.name + "': " + added.error().to_string();
      }
    }
  }
  if (pending.size() != record.images.size() && failure.empty()) failure = "not every image could be resumed";
  if (!failure.empty()) return false;
  resumed_at = wall();
  if (auto restored = broker.restore(record.queues); !restored) {
    failure = "queue state: " + std::string(broker::to_string(restored.error()));
    return false;
  }
  if (observer != nullptr) observer->on_restore(record.g, broker);
  for (const image::SavedService& saved : record.services) {
    ServiceRuntime& s = services[saved.service.value()];
    s.subscriptions = saved.subscriptions;
    // DESIGN §7 step 3: periodic timers realign to now (their phase within the period is kept), one-shot
    // timers shift by now − t_cp: both are the saved expiry moved by now − t_cp.
    for (const clock::KernelTimer& t : saved.timers) {
      (void)timers.arm(s.id, t.id, now() + (t.due - record.t_cp), t.period);
    }
  }
  time_page.write(clock::TimeSample{.now = now(), .mode = caps.mode(), .epoch = next});
  return true;
}

void Kernel::Impl::run_rollback(const std::string& reason) {
  const Nanos t0 = wall();
  // A checkpoint asked for by an incarnation that is about to die is void: nobody waits for its answer.
  if (checkpoint_request && checkpoint_request->first && services[checkpoint_request->first->value()].rejuvenate) {
    checkpoint_request.reset();
  }
  // The network is revoked before anything else happens; sr_mode is published once the services are back
  // (the ones about to die need not be woken for it).
  if (auto changed = caps.apply_mode(SrMode::RB); !changed) {
    log("mode RB: %s", std::string(cap::to_string(changed.error())).c_str());
  }
  time_page.write(clock::TimeSample{.now = now(), .mode = SrMode::RB, .epoch = time_page.current().epoch});
  sr_event(SrEventKind::Mode);
  retire_live_rejuvenated();
  const Nanos t_killed = wall();
  Nanos t_resumed = t_killed;
  // Real time, or lockstep charging the measured duration: the vehicle waits with us, and each generation
  // has resume_deadline. Otherwise the whole rollback has unseen_resume_deadline, and a fallback at least
  // resume_deadline (KernelOptions): below the plant's ack timeout however many generations are kept.
  const Nanos bound = image_wait_bound();
  const Nanos unseen_by = t_killed + bound;
  image::GenerationRecord* restored = nullptr;
  while (image::GenerationRecord* record = images.newest()) {
    std::string failure;
    if (observer != nullptr) observer->on_image_phase(ImagePhase::RollbackKilled, record->g);
    if (const auto dead = record->dead_image()) {
      const image::Image* im = record->image_of(*dead);
      failure = "the image of '" + services[dead->value()].name + "' is gone" +
                (im != nullptr && !im->last_death.empty() ? " (" + im->last_death + ")" : "");
    } else if (resume_generation(*record, std::max(unseen_by, wall() + options.resume_deadline), failure, t_resumed)) {
      restored = record;
      break;
    }
    log("rollback: generation %llu unusable (%s); falling back", num(record->g), failure.c_str());
    ++sr_stats.fallbacks;
    retire_live_rejuvenated();  // whatever of it was resumed
    if (auto taken = images.take(record->g)) retire(std::move(*taken));
  }
  if (restored == nullptr) {
    cold_restart(reason + "; no usable generation");
    return;
  }
  // The rollback is the rejuvenation: a pending once-timer is spent; a periodic one runs on.
  rejuvenation.due = rejuvenation.period > Nanos{0} ? std::optional<Nanos>(now() + rejuvenation.period) : std::nullopt;
  arm_timerfd();
  const Epoch epoch = time_page.current().epoch;
  // Published into the rings, delivered after the timed part (as after a checkpoint's commit): a service
  // woken by a delivery, or the plant's thread woken by a DDS write, may take the CPU at once.
  routing_frozen = true;
  if (const auto topic = kernel_topic(msgs::TopicTraits<rejuv_msg_RollbackSignal>::name)) {
    const rejuv_msg_RollbackSignal signal{.timestamp_ns = static_cast<std::uint64_t>(now().count()),
                                          .generation = restored->g.value(),
                                          .epoch = epoch.value()};
    publish_as_kernel(*topic, std::as_bytes(std::span(&signal, 1)));
  }
  publish_sr_mode();
  const Nanos took = wall() - t0;  // restored: the timed part ends here, as a checkpoint's does at its commit
  resume_routing();
  sr_stats.rollback_phases.a.add(to_ms(t_killed - t0));
  sr_stats.rollback_phases.b.add(to_ms(t_resumed - t_killed));
  sr_stats.rollback_phases.c.add(to_ms(t0 + took - t_resumed));
  sweep_strays("a rollback", false, SweepWait::ForCopies);  // as after a commit: before the new spares go out
  for (image::Image& im : restored->images) (void)im.request_spare(restored->g);  // g restorable again, async
  sr_event(SrEventKind::Rollback, restored->g, took);
  ++sr_stats.rollbacks;
  sr_stats.rollback_ms.add(to_ms(took));
  charge_image_work(took, rollback_charge);
  if (options.verbose) {
    log("rollback to generation %llu (epoch %u) in %.3f ms: %s", num(restored->g), epoch.value(), to_ms(took),
        reason.c_str());
  }
}

void Kernel::Impl::cold_restart(const std::string& reason) {
  log("cold restart of the rejuvenated services from their binaries, in SC: %s", reason.c_str());
  ++sr_stats.cold_restarts;
  sr_event(SrEventKind::ColdRestart);
  for (image::GenerationRecord& r : images.take_all()) retire(std::move(r));
  retire_live_rejuvenated();
  kill_retired();
  rejuvenation = RejuvenationTimer{};
  arm_timerfd();
  const Epoch next{time_page.current().epoch.value() + 1};
  time_page.write(clock::TimeSample{.now = now(), .mode = caps.mode(), .epoch = next});
  set_mode(SrMode::SC);  // safe, network off
  for (ServiceRuntime& s : services) {
    if (!s.rejuvenate || s.skip) continue;
    s.subscriptions.clear();
    s.params = build_params(*this, s);  // boot.cold_restarts: the estimator starts from the sensors
    s.idle_count = 0;
    s.frames_base = s.stats.frames_out;
    if (auto ok = spawn_one(s); !ok) {
      stop_run(StopReason::ServiceFailed, "cold restart: " + ok.error().message);
      return;
    }
  }
  // Booted here, like at start (Kernel::boot), so that no step runs with half a graph. A service that does
  // not come up ends the run: there is nothing left to fall back to.
  const auto restarted = [&](const auto& pred) {
    return std::any_of(services.begin(), services.end(), [&](const ServiceRuntime& s) {
      return s.rejuvenate && !s.skip && pred(s);
    });
  };
  while (!stopping && restarted([](const ServiceRuntime& s) { return s.phase == Phase::Spawned || s.phase == Phase::Booted; })) {
    if (!pump(options.boot_deadline)) break;
  }
  rollback_request.reset();
  if (restarted([](const ServiceRuntime& s) { return s.phase != Phase::Ready; })) {
    stop_run(StopReason::ServiceFailed, "cold restart: a rejuvenated service did not boot");
  }
}

Result<void, KernelError> Kernel::Impl::settle_images() {
  while (!stopping && (checkpoint_request || rollback_request)) {
    if (service_images()) continue;
    if (auto ok = pump(std::chrono::milliseconds{100}); !ok) return ok;
  }
  return {};
}

// ---- the rejuvenation timer ----

void Kernel::Impl::arm_rejuvenation(ServiceRuntime& s, std::uint32_t seq, Nanos after, Nanos period) {
  const Epoch epoch = time_page.current().epoch;
  if (rejuvenation.armed_in == epoch) {
    // DESIGN §7: at most one arm per epoch, so the recursive do_timer of §V-C (Fig. 8) cannot happen.
    ++sr_stats.timer_arm_refused;
    log("'%s' armed the rejuvenation timer a second time in epoch %u: refused", s.name.c_str(), epoch.value());
    sr_event(SrEventKind::TimerRefused, {}, after, s.id);
    reply(s, seq, op_code(wire::OpError::Refused));
    return;
  }
  if (after <= Nanos{0} || period < Nanos{0}) {
    reply(s, seq, op_code(wire::OpError::BadArgument));
    return;
  }
  rejuvenation = RejuvenationTimer{.due = now() + after, .period = period, .armed_in = epoch};
  ++sr_stats.timer_arms;
  sr_event(SrEventKind::TimerArmed, {}, after, s.id);
  arm_timerfd();
  reply(s, seq, 0, static_cast<std::uint64_t>(rejuvenation.due->count()));
}

void Kernel::Impl::fire_rejuvenation() {
  if (!rejuvenation.due || *rejuvenation.due > now()) return;
  rejuvenation.due.reset();
  ++sr_stats.timer_rollbacks;
  request_rollback("the rejuvenation timer fired");
}

}  // namespace rejuv::kernel
