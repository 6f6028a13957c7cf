// Rejuvenator: checkpoint g (docs/design.md §7 "Checkpoint g"; the overview is at the top of
// rejuvenator.cpp): at a quiescent point routing freezes, every live rejuvenated service gets a Snapshot and
// answers Taken (an image by fork) or TakenPages (its written pages, made into an image off the critical path
// by a copy of the base image: send_patches); publications that arrive before their sender's Taken are
// applied to the rings; then the kernel state is saved whole beside the images (save_state), the generation
// committed and the caller answered. A refused or late Taken abandons the generation (a late service is
// killed).
#include <fcntl.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "images.hpp"

namespace rejuv::kernel {

bool Rejuvenator::quiescent_for_checkpoint() const {
  const std::optional<ServiceId> caller = coordinator_.asked_by();
  return std::all_of(k.services.begin(), k.services.end(), [&](const ServiceRuntime& s) {
    if (!s.live()) return true;
    if (s.proc.phase() != Phase::Ready || !s.flow().drained()) return false;
    return k.clock_mode == ClockMode::Realtime || s.id == caller || s.idle();
  });
}

// ---- checkpoint ----

bool Rejuvenator::lost_during(CheckpointRun& run) const {
  // A service of the checkpoint that died before the commit — before its Taken (it will never answer) or after
  // it — has left the broker and the timer table (on_child_exit): the generation would lack its kernel objects
  // and an image restored from it would receive nothing (the fault campaign: ekf2 killed right after its Taken,
  // restored deaf, the vehicle lost). Not a generation.
  if (!run.failure.empty()) return true;
  for (const image::Image& im : run.record.images) {
    const ServiceRuntime& s = k.services[im.service.value()];
    if (!s.live()) {
      run.failure = "'" + s.name + "' was lost during the checkpoint";
      return true;
    }
  }
  return false;
}

// The checkpoint asked for, from the cut to the caller's answer: Snapshots out, every image awaited, then
// the generation committed or abandoned.
void Rejuvenator::run_checkpoint() {
  if (coordinator_.work_left()) run_image_work();  // the last checkpoint's or rollback's, if the vehicle has not had its update yet
  CheckpointTimes times{.start = k.wall()};
  CheckpointRun& run = coordinator_.begin_checkpoint(images_.next_generation(), k.now());
  routing_.freeze();
  k.router.flush_staged();  // the round's publications so far: before the cut, into the rings, undelivered
  send_snapshots(run);
  times.sent = k.wall();
  if (k.observer != nullptr) k.observer->on_image_phase(ImagePhase::CheckpointSnapshotsSent, run.record.g);
  const bool late = await_images(run);
  CheckpointRun done = coordinator_.end_checkpoint();
  if (done.failure.empty() && !done.waiting.empty()) done.failure = "the run is stopping";
  (void)lost_during(done);  // a death read in the last pump
  if (!done.failure.empty()) {
    abandon_checkpoint(std::move(done), late, times);
    return;
  }
  commit_checkpoint(std::move(done), times);
}

// A Snapshot with a fresh resume socket to every live rejuvenated service (the first failure stops them).
void Rejuvenator::send_snapshots(CheckpointRun& run) {
  const Generation g = run.record.g;
  for (ServiceRuntime& s : k.services) {
    if (!s.config.rejuvenate || s.proc.phase() != Phase::Ready) continue;
    auto pair = channel_pool.take();
    if (!pair) {
      run.failure = "resume socket: " + pair.error().to_string();
      break;
    }
    const Generation base = pages_base_for(s);
    // The pagemap goes with the first Snapshot that offers a base to this incarnation; the service keeps it.
    const bool with_pagemap = base.value() != 0 && !s.pages.pagemap_sent;
    const std::array<int, 2> fds{pair->second.fd(), s.pages.pagemap.get()};
    const wire::SnapshotBody body{.base = base.value()};
    if (!k.tx.build_with(wire::FrameKind::Snapshot, 0, 0, g.value(), body)) break;
    if (auto sent = s.proc.channel.send(k.tx.bytes(), std::span(fds).first(with_pagemap ? 2 : 1)); !sent) {
      run.failure = "Snapshot to '" + s.name + "': " + sent.error().to_string();
      break;
    }
    k.router.count_sent(s);
    if (with_pagemap) s.pages.pagemap_sent = true;
    // The image end stays with the kernel until the commit: by fork it is closed, by written pages it goes
    // to the copy of the base that becomes the image (send_patches).
    run.record.images.push_back(image::Image{.service = s.id, .copies = {}, .resume = std::move(pair->first),
                                             .base = base, .image_end = pair->second.take_fd()});
    run.waiting.push_back(s.id);
  }
}

// Handles every other event meanwhile (pump) until each service has answered, one is lost, or the snapshot
// deadline passes (true: late). Taken frames come through handle_frame → on_taken, TakenPages (with its fd)
// through read_channel → on_taken_pages. Past the deadline the kernel looks once more without waiting: what
// came while the kernel itself did not run (waiting for a CPU) was in time for all the services could tell.
bool Rejuvenator::await_images(CheckpointRun& run) {
  const Nanos deadline = k.wall() + wait_bound(k.options.snapshot_deadline, k.options.unseen_snapshot_deadline);
  bool looked_past = false;
  while (run.failure.empty() && !run.waiting.empty() && !k.stopping) {
    if (lost_during(run)) break;  // abandoned now rather than at the deadline
    const Nanos left = deadline - k.wall();
    if (left <= Nanos{0} && looked_past) {
      run.failure =
          "no Taken from '" + k.services[run.waiting.front().value()].name + "' within the snapshot deadline";
      return true;
    }
    looked_past = left <= Nanos{0};
    if (!k.pump(std::max(left, Nanos{0}))) break;
  }
  return false;
}

void Rejuvenator::answer_checkpoint(const CheckpointRun& run, std::int32_t error, std::uint64_t value) {
  if (run.caller) k.input.reply(k.services[run.caller->value()], run.seq, error, value);
}

// Not a generation: its images destroyed, a late service killed, routing resumed and the caller refused.
void Rejuvenator::abandon_checkpoint(CheckpointRun done, bool late, const CheckpointTimes& times) {
  const Generation g = done.record.g;
  if (!done.priming) {
    ++sr_stats_.checkpoint_failures;
    sr_event(SrEventKind::CheckpointFailed, g, k.wall() - times.start, done.caller);
  }
  k.log("%s %llu abandoned: %s", done.priming ? "the alignment's checkpoint" : "checkpoint", num(g),
        done.failure.c_str());
  coordinator_.abandoned(g, done.waiting);
  images_.abandon(g);
  image::destroy(done.record);
  if (late) {
    for (const ServiceId id : done.waiting) {
      ServiceRuntime& s = k.services[id.value()];
      // Runnable: waiting for a CPU (a loaded machine), not hung (cpu_wait.hpp). The generation is lost
      // either way (the vehicle waits with the checkpoint); the service is not: it answers late (late_image),
      // and if it spins, the liveness watch (real time) or the step's idle deadline (lockstep) judges it.
      const auto task = sys::task_cpu(s.proc.process.pid());
      if (task && task->runnable) {
        k.log("'%s' is waiting for a CPU at the snapshot deadline: not hung, the checkpoint only abandoned",
              s.name.c_str());
        continue;
      }
      // Asleep: it sent whatever it answered before it slept (the scheduler is read first), so its channel
      // holds a Taken sent after the kernel's last read, if there is one (settled by late_image).
      if (s.live() && s.proc.channel.valid()) k.input.read_channel(s);
      if (!coordinator_.owes(s.id)) {
        k.log("'%s' answered after the snapshot deadline: not hung, the checkpoint only abandoned",
              s.name.c_str());
        continue;
      }
      k.supervisor.kill_hung(s, std::string("no Taken within the snapshot deadline") +
                                    (task ? " (state " + std::string(1, task->state) + ")" : " (gone)"));
    }
  }
  resume_routing();
  answer_checkpoint(done, op_code(wire::OpError::Refused), 0);
}

// The generation committed with the kernel state beside it (docs/design.md §7 step 3), the caller answered, and what
// is left to do (patches, evicted generations, the sweep, the spares) left for after the vehicle's next update.
void Rejuvenator::commit_checkpoint(CheckpointRun done, CheckpointTimes times) {
  const Generation g = done.record.g;
  times.taken = k.wall();
  if (k.observer != nullptr) k.observer->on_image_phase(ImagePhase::CheckpointTaken, g);
  // Publications that reached the kernel before their sender's Taken: before the cut.
  k.router.flush_staged();
  done.record.state = save_state(done.t_cp, done.record.images, k.services, k.broker, k.timers);
  catch_up_.cut(g);  // every plant sample kept so far is in the queue state just saved
  if (k.observer != nullptr) k.observer->on_checkpoint(g, k.broker);
  for (const image::Image& im : done.record.images) {
    k.services[im.service.value()].pages.base = g;
    ++k.services[im.service.value()].stats.images;
  }
  std::vector<image::GenerationRecord> evicted = images_.commit(std::move(done.record));
  times.saved = k.wall();  // committed: the caller may go on (what follows is not on its path)
  resume_routing();
  answer_checkpoint(done, 0, g.value());  // its record is the store's now: caller and seq only
  // Each service of g prepares its next image now, in the slack the checkpoint started in (vehicle_pace.hpp),
  // instead of when the next sample wakes it: there it cost the control chain ≈ 0.4 ms in real time.
  for (const image::Image& im : images_.newest()->images) {
    if (k.tx.build(wire::FrameKind::Committed, 0, 0, g.value()))
      k.router.send_control(k.services[im.service.value()], k.tx.bytes());
  }
  const std::uint64_t forks_before = sr_stats_.images_by_fork;
  coordinator_.forget_abandoned();  // an image still owed to an abandoned checkpoint is a stray from now on
  // The patches (before old generations go: a base may be among them), the evicted generations, the stray
  // sweep (before the new spares are on their way, so that only copies asked for earlier can defer it) and the
  // spare copies: after the vehicle's next control update (leave_image_work).
  leave_image_work(
      ImageWork{.patches = g, .evicted = std::move(evicted), .sweep = "a checkpoint's commit",
                .sweep_wait = SweepWait::No, .spares = g});
  if (done.priming) {
    run_image_work();  // before the flight: nothing to wait for, and the count below needs it
    // docs/design.md §6: the alignment's images, by fork, are not part of the flight: neither counted nor charged.
    sr_stats_.priming_images += sr_stats_.images_by_fork - forks_before;
    sr_stats_.images_by_fork = forks_before;
    k.log("the alignment's checkpoint: %zu images by fork in %.3f ms (untimed, not charged)",
          images_.newest()->images.size(), to_ms(times.saved - times.start));
    return;
  }
  count_checkpoint(g, done.caller, times);
}

// A timed checkpoint in the run's statistics, its SR event and its charge in simulated time (docs/design.md §6).
void Rejuvenator::count_checkpoint(Generation g, std::optional<ServiceId> caller,
                                   const CheckpointTimes& times) {
  const Nanos took = times.saved - times.start;
  sr_stats_.checkpoint_phases.a.add(to_ms(times.sent - times.start));
  sr_stats_.checkpoint_phases.b.add(to_ms(times.taken - times.sent));
  sr_stats_.checkpoint_phases.c.add(to_ms(times.saved - times.taken));
  ++sr_stats_.checkpoints;
  sr_event(SrEventKind::Checkpoint, g, took, caller);
  sr_stats_.checkpoint_ms.add(to_ms(took));
  if (!sr_stats_.first_checkpoint_ms) sr_stats_.first_checkpoint_ms = to_ms(took);
  image_charge_.checkpoint(took, sr_stats_);
  if (k.options.verbose)
    k.log("checkpoint %llu: %zu images in %.3f ms", num(g), images_.newest()->images.size(), to_ms(took));
}

bool Rejuvenator::late_image(ServiceRuntime& s, const wire::FrameView& frame) {
  if (!coordinator_.settle_owed(Generation(frame.header.aux), s.id)) return false;
  // TakenPages: its pages fd closes with the frame. Taken: the image is a process of the service's session
  // that the kernel made it fork and no longer wants. Anything else the pid could name is left alone.
  if (frame.kind != wire::FrameKind::Taken) return true;
  const pid_t pid = wire::payload_as<wire::TakenBody>(frame).image_pid;
  if (pid <= 0 || knows_process(pid, nullptr)) return true;
  const auto sid = sys::session_of(pid);
  if (sid && std::find(s.sandbox.sessions.begin(), s.sandbox.sessions.end(), *sid) != s.sandbox.sessions.end()) {
    (void)sys::kill_and_reap_own_child(pid);
  }
  return true;
}

bool Rejuvenator::expecting_image(ServiceRuntime& s, const wire::FrameView& frame) {
  if (late_image(s, frame)) return false;  // the answer of an abandoned checkpoint: not a protocol error
  CheckpointRun* running = coordinator_.running();
  if (running == nullptr) {
    k.refuse(s, std::string(wire::to_string(frame.kind)) + " without a checkpoint in progress");
    return false;
  }
  CheckpointRun& run = *running;
  const auto waiting = std::find(run.waiting.begin(), run.waiting.end(), s.id);
  if (waiting == run.waiting.end()) {
    k.refuse(s, std::string(wire::to_string(frame.kind)) + " it was not asked for");
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

Generation Rejuvenator::pages_base_for(const ServiceRuntime& s) {
  const Generation base = s.pages.base;
  if (!k.options.images_by_pages || base.value() == 0 || images_.keep() < 2) return Generation{};
  if (!s.pages.pagemap.valid()) return Generation{};
  // The base must outlive this checkpoint's commit, which keeps the newest keep − 1 generations and the new one.
  const std::vector<Generation> kept = images_.generations();
  const std::size_t survivors = std::min(kept.size(), images_.keep() - 1);
  if (std::find(kept.end() - static_cast<std::ptrdiff_t>(survivors), kept.end(), base) == kept.end()) return Generation{};
  image::GenerationRecord* record = images_.find(base);
  image::Image* im = record != nullptr ? record->image_of(s.id) : nullptr;
  // No refresh() here (a receive and a wait per copy, on the critical path): a copy that died since is found
  // when the Patch goes unanswered, and a rollback to this generation falls back (dead_image).
  if (im == nullptr || !im->has_copy_or_patch()) return Generation{};
  return base;
}

void Rejuvenator::on_taken_pages(ServiceRuntime& s, const wire::FrameView& frame, sys::UniqueFd pages) {
  if (!expecting_image(s, frame)) return;
  CheckpointRun& run = *coordinator_.running();
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

void Rejuvenator::send_patches(image::GenerationRecord& record) {
  for (image::Image& im : record.images) {
    if (!im.pages.valid()) {  // by fork: the image is its own process
      ++sr_stats_.images_by_fork;
      channel_pool.close_later(std::move(im.image_end));
      continue;
    }
    ++sr_stats_.images_by_pages;
    image::GenerationRecord* base = images_.find(im.base);
    image::Image* from = base != nullptr ? base->image_of(im.service) : nullptr;
    const wire::PatchBody body{.generation = record.g.value(), .pages = im.page_count};
    const std::array<int, 2> fds{im.pages.get(), im.image_end.get()};
    if (from != nullptr && k.tx.build_with(wire::FrameKind::Patch, 0, 0, im.base.value(), body) &&
        from->resume.send(k.tx.bytes(), fds)) {
      im.patch_pending = true;
    } else {  // no image: a rollback to this generation falls back (image::GenerationRecord::dead_image)
      k.log("generation %llu: no copy of generation %llu's image of '%s' to make its image from",
            num(record.g), num(im.base), k.services[im.service.value()].name.c_str());
    }
    channel_pool.close_later(std::move(im.pages));
    channel_pool.close_later(std::move(im.image_end));
  }
}

bool Rejuvenator::knows_process(pid_t pid, const image::GenerationRecord* taking) const {
  const auto in = [&](const image::GenerationRecord& r) {
    return std::any_of(r.images.begin(), r.images.end(), [&](const image::Image& i) {
      return std::any_of(i.copies.begin(), i.copies.end(), [&](const sys::ChildProcess& c) { return c.pid() == pid; });
    });
  };
  return images_.owns(pid) || k.supervisor.plant_pid() == pid ||
         std::any_of(k.services.begin(), k.services.end(),
                     [&](const ServiceRuntime& o) { return o.proc.process.pid() == pid; }) ||
         (taking != nullptr && in(*taking));
}

void Rejuvenator::on_taken(ServiceRuntime& s, const wire::FrameView& frame) {
  if (!expecting_image(s, frame)) return;
  CheckpointRun& run = *coordinator_.running();
  const wire::TakenBody body = wire::payload_as<wire::TakenBody>(frame);
  const pid_t pid = body.image_pid;
  if (pid <= 0) {
    // The errno the service says its fork failed with, if any (a service's word: only for the log).
    const int err = body.reserved <= 4095 ? static_cast<int>(body.reserved) : 0;
    run.failure = "'" + s.name + "' could not take its image" +
                  (err != 0 ? std::string(" (fork: ") + std::strerror(err) + ")" : std::string());
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

}  // namespace rejuv::kernel
