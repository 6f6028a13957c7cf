// Rejuvenator: rollback (docs/design.md §7 "Rollback"; the overview is at the top of rejuvenator.cpp), on the
// rejuvenation timer, a CheckpointRollback or a rejuvenated service lost: mode RB, every live rejuvenated
// incarnation retired (cut off, its leaf killed with cgroup.kill or, without it, stopped with SIGSTOP and
// killed after the timed part), the images of the newest intact
// generation resumed on new channels and the kernel state restored whole (restore_state); a dead image or a
// failed resume falls back to the previous generation, then to a cold restart of the rejuvenated services
// from their binaries in SC.
#include <algorithm>
#include <array>
#include <csignal>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cpu_wait.hpp"
#include "images.hpp"

namespace rejuv::kernel {

// ---- rollback ----

void Rejuvenator::request_rollback(std::string reason) {
  coordinator_.ask_rollback(std::move(reason));
}

void Rejuvenator::retire_live_rejuvenated() {
  k.lockstep.drop_publications_of([&](std::uint32_t publisher) { return k.services[publisher].config.rejuvenate; });
  for (ServiceRuntime& s : k.services) {
    if (!s.config.rejuvenate || s.config.skip || s.proc.phase() == Phase::NotStarted) continue;
    // The live incarnation and everything it forked (strays are born in its leaf) ended in one call, however
    // many the attacker made (cgroup.kill of the live leaf, docs/sandbox.md); the images are in a leaf of
    // their own. The strays' zombies are reaped by the sweep after the rollback.
    const bool leaf_killed = k.warden.kill_live_leaf(s);
    if (s.live()) {
      // Out of the rollback's way before any image is resumed and before the epoch changes: killed with its
      // leaf, or (no cgroup.kill) stopped (Reaper::retire: SIGSTOP, every thread) and killed after the
      // rollback at a safe point (Reaper::kill_retired). With its channel out of the loop, no signal to
      // another process and no socket (seccomp), it cannot slow the rollback down or reach anything.
      (void)k.epoll.remove(s.proc.process.pidfd());
      if (leaf_killed) {
        reaper_.kill(std::move(s.proc.process));  // also where it was not yet moved into the leaf (CgroupPlacer)
      } else {
        reaper_.retire(std::move(s.proc.process));
      }
      s.proc.process = sys::ChildProcess{};
    }
    if (s.proc.channel.valid()) {
      (void)k.epoll.remove(s.proc.channel.fd());
      channel_pool.close_later(s.proc.channel.take_fd());  // closed off the critical path (refill_pairs)
    }
    s.proc.ended();
    k.broker.remove_service(s.id);
    k.timers.remove_service(s.id);
    k.router.channel_closed(s);
    s.proc.channel_closed_at.reset();
    s.proc.loss_reason.clear();
  }
}

namespace {
// An image whose Resume went out: the kernel's ends of its new channel and of its new output pipe, until it answers.
struct PendingResume {
  ServiceRuntime* service = nullptr;
  image::Image* image = nullptr;
  sys::SeqPacket channel{};  // the kernel's end of the new channel
  sys::UniqueFd output{};    // the read end of the restored incarnation's new stdout/stderr pipe
};

// The images a Resume went out to, and why it did not go out to the rest (empty: it went to all, or the frame
// could not be built, which the caller finds by the count).
struct ResumesSent {
  std::vector<PendingResume> pending;
  std::string failure;
};

// All Resumes first: the images wake in parallel. No fork here: a spare copy takes the Resume. Stops at the
// first image it cannot send one to.
ResumesSent send_resumes(Kernel::Impl& k, ChannelPool& channel_pool, image::GenerationRecord& record, Epoch next) {
  ResumesSent sent;
  sent.pending.reserve(record.images.size());
  for (image::Image& im : record.images) {
    ServiceRuntime& s = k.services[im.service.value()];
    auto channel = channel_pool.take();
    if (!channel) {
      sent.failure = "channel for a restored image: " + channel.error().to_string();
      break;
    }
    // A new pipe for fds 1-2 as well (docs/design.md §7 "Nothing outlives an incarnation"): the image's were opened
    // before it and shared with the incarnation it was taken from, which may have armed them.
    auto output = sys::make_pipe();
    if (!output) {
      sent.failure = "output pipe for a restored image: " + output.error().to_string();
      break;
    }
    const wire::ResumeBody body{.epoch = next.value(), .reserved = 0};
    if (!k.tx.build_with(wire::FrameKind::Resume, 0, 0, record.g.value(), body)) break;
    const std::array<int, 2> service_ends{channel->second.fd(), output->write.get()};
    if (auto resumed = im.resume.send(k.tx.bytes(), service_ends); !resumed) {
      sent.failure = "Resume to the image of '" + s.name + "': " + resumed.error().to_string();
      break;
    }
    // Closed now, not after the timed part: then the image's end is the channel's only other end, and a copy
    // that dies after taking its Resume hangs the channel up at once instead of costing the resume deadline.
    (void)channel->second.take_fd();
    output->write.reset();
    sent.pending.push_back(PendingResume{.service = &s, .image = &im, .channel = std::move(channel->first),
                                         .output = std::move(output->read)});
  }
  return sent;
}

// The process that answered `answer` (a copy of the image, or a spare whose Copied is still on its way), taken
// out of the image; nothing if no such process is ours.
std::optional<sys::ChildProcess> take_resumed_process(image::Image& im, pid_t pid) {
  if (pid <= 0) return std::nullopt;
  auto copy = std::find_if(im.copies.begin(), im.copies.end(),
                           [&](const sys::ChildProcess& c) { return c.pid() == pid; });
  if (copy != im.copies.end()) {
    sys::ChildProcess process = std::move(*copy);
    im.copies.erase(copy);
    return process;
  }
  if (auto spare = sys::ChildProcess::adopt_child(pid)) return std::move(*spare);
  return std::nullopt;
}

// The processes that may have taken `im`'s Resume, or still have to make the image that takes it: its copies;
// while a spare or its patch is on its way (a pid not known until its Copied), the kernel's children it knows
// nothing of (every spare in flight, a superset); and while its patch is, the copies of its base's image,
// which fork the copy the patch goes to.
std::vector<pid_t> owing_resumed(const Kernel::Impl& k, ServiceId service, const image::Image& im) {
  std::vector<pid_t> pids;
  for (const sys::ChildProcess& c : im.copies) pids.push_back(c.pid());
  if (im.spares_pending > 0 || im.patch_pending) {
    for (const pid_t pid : sys::own_children().value_or(std::vector<pid_t>{})) {
      if (!k.warden.known_child(pid)) pids.push_back(pid);
    }
  }
  const image::GenerationRecord* base = im.patch_pending ? k.rejuvenator.images().find(im.base) : nullptr;
  if (const image::Image* from = base != nullptr ? base->image_of(service) : nullptr) {
    for (const sys::ChildProcess& c : from->copies) pids.push_back(c.pid());
  }
  return pids;
}

// "pid 12 R, pid 13 D": what the scheduler shows of each of `pids` now (for a log line).
std::string states_of(std::span<const pid_t> pids) {
  std::string states;
  for (const pid_t pid : pids) {
    const auto cpu = sys::task_cpu(pid);
    states += (states.empty() ? "pid " : ", pid ") + std::to_string(pid) + " " + (cpu ? cpu->state : '-');
  }
  return states;
}

// The first frame on p's new channel: Resumed{g, its pid}; otherwise why not (a hang-up, no frame in time,
// another frame), with the wall time waited. In time: before wait's deadline, or later while what owes the
// answer waits for a CPU (owing_resumed; cpu_wait.hpp: a starved image is not lost).
std::expected<pid_t, std::string> read_resumed(Kernel::Impl& k, const PendingResume& p, Generation g,
                                               CpuWait wait) {
  const Nanos start = sys::monotonic_now();
  const auto waited = [&] { return std::to_string(to_ms(sys::monotonic_now() - start)) + " ms"; };
  Nanos until = wait.deadline_at();
  for (;;) {
    const Nanos left = std::max(Nanos{0}, until - sys::monotonic_now());
    auto ready = sys::wait_fd(p.channel.fd(), sys::WaitFor::Readable, left);
    if (!ready) return std::unexpected("waiting: " + ready.error().to_string());
    if (*ready) break;
    const std::vector<pid_t> owing = owing_resumed(k, p.service->id, *p.image);
    const std::optional<CpuWait::GoOn> on = wait.go_on(sys::monotonic_now(), cpu_sight(owing));
    if (!on) {
      // The scheduler was read first: an image seen asleep sent its Resumed before it slept, if it did.
      auto last = sys::wait_fd(p.channel.fd(), sys::WaitFor::Readable, Nanos{0});
      if (last && *last) break;
      return std::unexpected("no answer in " + waited() +
                             (owing.empty() ? "" : " (" + states_of(owing) + ")"));
    }
    if (on->first) {
      k.log("rollback: the image of '%s' is waiting for a CPU at its deadline (%s): not lost, waited on",
            p.service->name.c_str(), states_of(owing).c_str());
    }
    until = on->until;
  }
  if (wait.went_on()) {
    k.log(
        "rollback: the image of '%s' is readable %.1f ms past its deadline (the vehicle's controls held "
        "meanwhile)",
        p.service->name.c_str(), to_ms(sys::monotonic_now() - wait.deadline_at()));
  }
  std::array<std::byte, sizeof(wire::FrameHeader) + sizeof(wire::TakenBody)> buf{};
  auto got = p.channel.receive(buf);
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

// Installs the incarnation restored from p's image as the live service as soon as it answers (read_resumed;
// on a failure the caller retires it again); the first thing that went wrong, if anything did.
Result<void, std::string> install_resumed(Kernel::Impl& k, PendingResume& p, Generation g, CpuWait wait) {
  ServiceRuntime& s = *p.service;
  const image::Image& im = *p.image;
  const auto answer = read_resumed(k, p, g, wait);
  const pid_t pid = answer.value_or(0);
  std::optional<sys::ChildProcess> process = take_resumed_process(*p.image, pid);
  if (!process) {
    const std::string why = answer ? "pid " + std::to_string(pid) + " is no copy" : answer.error();
    k.warden.record_violation(s, Violation::ImageLost,
                              "generation " + std::to_string(g.value()) + ": no Resumed (" + why + ")");
    return std::unexpected("no Resumed from the image of '" + s.name + "': " + why + " (" +
                           std::to_string(im.copies.size()) + " copies, " + std::to_string(im.spares_pending) +
                           " spares and " + (im.patch_pending ? "its patch" : "no patch") + " on their way" +
                           (im.last_death.empty() ? "" : "; " + im.last_death) + ")");  // its copies die with g
  }
  std::string failure;
  s.proc.process = std::move(*process);
  p.image->resumed.push_back(pid);
  s.pages.start_incarnation(g);
  s.proc.channel = std::move(p.channel);
  if (auto watched = k.warden.replace_output(s, std::move(p.output)); !watched) {
    failure = "watching the restored '" + s.name + "' output: " + watched.error().to_string();
  }
  s.proc.resumed();
  k.router.channel_opened(s);
  s.stats.pid = s.proc.process.pid();
  k.warden.place_live(s);  // out of the images' leaf, into the one its forks and its memory are bounded in
  ++s.stats.restores;
  // A restored incarnation the loop does not watch would die unnoticed (no rollback, no restart): the
  // generation is unusable rather than half-installed.
  for (const auto& [fd, source] :
       {std::pair{s.proc.channel.fd(), Source::Channel}, std::pair{s.proc.process.pidfd(), Source::Pidfd}}) {
    if (auto added = k.epoll.add(fd, token(source, s.id.value())); !added && failure.empty()) {
      failure = "watching the restored '" + s.name + "': " + added.error().to_string();
    }
  }
  if (!failure.empty()) return std::unexpected(std::move(failure));
  return {};
}
}  // namespace

Result<Nanos, std::string> Rejuvenator::resume_generation(image::GenerationRecord& record,
                                                          const CpuWait& wait) {
  const Epoch next = k.kernel_clock.next_epoch();
  ResumesSent sent = send_resumes(k, channel_pool, record, next);
  std::string failure = std::move(sent.failure);
  if (k.observer != nullptr) k.observer->on_image_phase(ImagePhase::RollbackResumesSent, record.g);
  // Then every Resumed, each installed as it answers; every image is waited for, whatever failed first, each
  // with a copy of `wait` (its own count of CPU time; one limit for all).
  for (PendingResume& p : sent.pending) {
    if (auto installed = install_resumed(k, p, record.g, wait); !installed && failure.empty()) {
      failure = std::move(installed.error());
    }
  }
  if (sent.pending.size() != record.images.size() && failure.empty()) failure = "not every image could be resumed";
  if (!failure.empty()) return std::unexpected(std::move(failure));
  const Nanos resumed_at = k.wall();
  if (auto restored = restore_state(record.state, k.now(), k.services, k.broker, k.timers); !restored) {
    return std::unexpected("queue state: " + std::string(broker::to_string(restored.error())));
  }
  if (k.observer != nullptr) k.observer->on_restore(record.g, k.broker);
  k.kernel_clock.begin_epoch();  // = next, told to the images in their Resume
  return resumed_at;
}

std::optional<std::string> Rejuvenator::lost_image(image::GenerationRecord& record) {
  const std::optional<ServiceId> dead = images_.dead_image(record);
  if (!dead) return std::nullopt;
  const image::Image* im = record.image_of(*dead);
  std::string failure = "the image of '" + k.services[dead->value()].name + "' is gone" +
                        (im != nullptr && !im->last_death.empty() ? " (" + im->last_death + ")" : "");
  k.warden.record_violation(k.services[dead->value()], Violation::ImageLost,
                            "generation " + std::to_string(record.g.value()) + ": " + failure);
  return failure;
}

// Real time, where the vehicle's controls are held while the rollback waits: when an image of the newest
// generation has no copy free to take its Resume now (its Patch, or a fork its copy makes, on its way:
// ImageStore::free_to_resume; a fork can wait a second on a busy machine, for the locks of the files every
// process maps), the newest older generation that is free, if one is. The newer ones stay in the store, as
// fallbacks for a later rollback (each is a clean state, as the one resumed). nullptr: the newest is resumed
// and waited for (cpu_wait.hpp) — it is free, none is, or one on the way is lost (resume_newest_usable
// records the loss). Lockstep never passes over: the world waits there, and the generation resumed must not
// depend on the machine's pace.
image::GenerationRecord* Rejuvenator::free_before_busy() {
  if (k.clock_mode != ClockMode::Realtime) return nullptr;
  // The common case without a system call, on what the store knew at its last refresh: a Copied not read
  // since makes the newest look busy (then judged again below, refreshed), a copy dead since makes it look
  // free (then the resume finds it dead and falls back, as it would have without this look).
  const image::GenerationRecord* newest = images_.newest();
  if (newest == nullptr || images_.free_to_resume(*newest)) return nullptr;
  const std::vector<Generation> gens = images_.generations();  // oldest first
  for (auto g = gens.rbegin(); g != gens.rend(); ++g) {
    image::GenerationRecord* record = images_.find(*g);
    // dead_image reads its images' answers first (Image::refresh): newest first, so that the patches counted
    // against an older one's copies are up to date when it is judged.
    if (record == nullptr || images_.dead_image(*record)) return nullptr;
    if (!images_.free_to_resume(*record)) continue;
    if (g == gens.rbegin()) return nullptr;
    k.log("rollback: generation %llu resumed before %llu, kept, of which an image has no copy free to take "
          "the Resume now (a fork on its way; the vehicle's controls are held while a rollback waits)",
          num(*g), num(gens.back()));
    ++sr_stats_.passed_over;
    return record;
  }
  return nullptr;
}

// `record` resumed; else retired, counted as a fallback, and why logged.
std::optional<Rejuvenator::ResumedGeneration> Rejuvenator::resume_or_retire(image::GenerationRecord& record,
                                                                            Nanos rollback_by) {
  if (k.observer != nullptr) k.observer->on_image_phase(ImagePhase::RollbackKilled, record.g);
  std::string failure;
  if (std::optional<std::string> lost = lost_image(record)) {
    failure = std::move(*lost);
  } else if (auto resumed = resume_generation(
                 record, CpuWait(std::max(rollback_by, k.wall() + k.options.resume_deadline),
                                 image_wait_bound(), rollback_by - image_wait_bound()))) {
    return ResumedGeneration{.record = &record, .resumed_at = *resumed};
  } else {
    failure = std::move(resumed.error());
  }
  k.log("rollback: generation %llu unusable (%s); falling back", num(record.g), failure.c_str());
  ++sr_stats_.fallbacks;
  retire_live_rejuvenated();  // whatever of it was resumed
  if (auto taken = images_.take(record.g)) retire(std::move(*taken));
  return std::nullopt;
}

std::optional<Rejuvenator::ResumedGeneration> Rejuvenator::resume_newest_usable(Nanos rollback_by) {
  if (image::GenerationRecord* free = free_before_busy()) {
    if (std::optional<ResumedGeneration> resumed = resume_or_retire(*free, rollback_by)) return resumed;
  }
  while (image::GenerationRecord* record = images_.newest()) {
    if (std::optional<ResumedGeneration> resumed = resume_or_retire(*record, rollback_by)) return resumed;
  }
  return std::nullopt;
}

// The RollbackSignal and the SrMode, published into frozen rings and delivered after the timed part (as after a
// checkpoint's commit): a service woken by a delivery, or the plant's thread woken by a DDS write, may take the
// CPU at once.
void Rejuvenator::announce_rollback(Generation g, Epoch epoch) {
  routing_.freeze();
  KernelMessage<rejuv_msg_RollbackSignal> signal;
  signal.fields.timestamp_ns = static_cast<std::uint64_t>(k.now().count());
  signal.fields.generation = g.value();
  signal.fields.epoch = epoch.value();
  // With the catch-up a replay follows (or, for want of one, a CATCH_UP_REARM or CATCH_UP_DONE at once).
  signal.fields.catch_up = catch_up_.enabled() ? rejuv_msg_CATCH_UP_REPLAY : rejuv_msg_CATCH_UP_OFF;
  signal.fields.replayed_to_ns = 0;
  k.router.publish_kernel_message(signal);
  k.router.publish_sr_mode();
}

void Rejuvenator::run_rollback(const std::string& reason) {
  if (coordinator_.work_left()) run_image_work();  // the newest generation's patches first: the rollback resumes them
  const Nanos t0 = k.wall();
  // A checkpoint asked for by an incarnation that is about to die is void: nobody waits for its answer.
  if (coordinator_.checkpoint() == ImageCoordinator::Checkpoint::Asked) {
    const std::optional<ServiceId> by = coordinator_.asked_by();
    if (by && k.services[by->value()].config.rejuvenate) coordinator_.void_ask();
  }
  // The network is revoked before anything else happens; sr_mode is published once the services are back
  // (the ones about to die need not be woken for it).
  (void)enter_mode(SrMode::RB);
  sr_event(SrEventKind::Mode);
  retire_live_rejuvenated();
  const Nanos t_killed = k.wall();
  // The whole rollback has image_wait_bound() (resume_deadline where the vehicle waits with us,
  // unseen_resume_deadline otherwise): below the plant's ack timeout however many generations are kept.
  const std::optional<ResumedGeneration> resumed = resume_newest_usable(t_killed + image_wait_bound());
  if (!resumed) {
    cold_restart(reason + "; no usable generation");
    return;
  }
  image::GenerationRecord* const restored = resumed->record;
  const Nanos t_resumed = resumed->resumed_at;
  // The rollback is the rejuvenation: a pending once-timer is spent; a periodic one runs on.
  coordinator_.rejuvenated(k.now());
  k.arm_timerfd();
  const Epoch epoch = k.kernel_clock.epoch();
  announce_rollback(restored->g, epoch);
  const Nanos took = k.wall() - t0;  // restored: the timed part ends here, as a checkpoint's does at its commit
  resume_routing();
  // The restored estimator chain is fed the plant's samples since g's cut before the step goes on (lockstep.cpp).
  // Without them the estimator re-arms from the live samples (§IV); with none to replay it is current already.
  switch (catch_up_.begin(restored->g, k.wall())) {
    case CatchUp::Begin::Replaying: break;
    case CatchUp::Begin::NothingToReplay:
      if (catch_up_.enabled()) signal_catch_up(rejuv_msg_CATCH_UP_DONE);
      break;
    case CatchUp::Begin::NoLog:
      k.log("rollback to generation %llu: its samples are no longer all kept; the estimator re-arms",
            num(restored->g));
      signal_catch_up(rejuv_msg_CATCH_UP_REARM);
      break;
  }
  // The restored copies ran SCHED_OTHER (reset on fork) until now: the real-time plan back, after the timed
  // part (realtime.cpp; a system call per service). The catch-up chain only once its replay is handled
  // (chain_realtime): its real-time budget is for live work.
  for (const image::Image& im : restored->images) {
    if (catch_up_.in_replay(im.service)) continue;
    k.supervisor.apply_realtime(k.services[im.service.value()]);
  }
  sr_stats_.rollback_phases.a.add(to_ms(t_killed - t0));
  sr_stats_.rollback_phases.b.add(to_ms(t_resumed - t_killed));
  sr_stats_.rollback_phases.c.add(to_ms(t0 + took - t_resumed));
  // As after a commit: the sweep before the new spares go out, and the spares (g restorable again) after the
  // vehicle's next control update; the retired incarnations stay stopped until then (leave_image_work).
  leave_image_work(ImageWork{.patches = {}, .evicted = {}, .sweep = "a rollback", .sweep_wait = SweepWait::ForCopies,
                             .spares = restored->g});
  sr_event(SrEventKind::Rollback, restored->g, took);
  ++sr_stats_.rollbacks;
  sr_stats_.rollback_ms.add(to_ms(took));
  image_charge_.rollback(took, sr_stats_);
  if (k.options.verbose) {
    k.log("rollback to generation %llu (epoch %u) in %.3f ms: %s", num(restored->g), epoch.value(),
          to_ms(took), reason.c_str());
  }
}

void Rejuvenator::signal_catch_up(rejuv_msg_EstimateCatchUp how) {
  KernelMessage<rejuv_msg_RollbackSignal> signal;
  signal.fields.timestamp_ns = static_cast<std::uint64_t>(k.now().count());
  signal.fields.generation = catch_up_.generation().value();
  signal.fields.epoch = k.kernel_clock.epoch().value();
  signal.fields.catch_up = how;
  signal.fields.replayed_to_ns = catch_up_.replayed_to();
  k.router.publish_kernel_message(signal);
}

void Rejuvenator::chain_realtime() {
  for (ServiceRuntime& s : k.services) {
    if (catch_up_.in_chain(s.id)) k.supervisor.apply_realtime(s);
  }
}

void Rejuvenator::catch_up_done() {
  chain_realtime();
  const Nanos took = k.wall() - catch_up_.began_at();
  sr_stats_.catch_up_ms.add(to_ms(took));
  image_charge_.catch_up(took, catch_up_.replayed(), sr_stats_);
}

void Rejuvenator::cold_restart(const std::string& reason) {
  k.log("cold restart of the rejuvenated services from their binaries, in SC: %s", reason.c_str());
  ++sr_stats_.cold_restarts;
  sr_event(SrEventKind::ColdRestart);
  if (std::optional<ImageWork> left = coordinator_.take_work()) {  // for generations that go now: only the evicted matter
    for (image::GenerationRecord& r : left->evicted) retire(std::move(r));
  }
  for (image::GenerationRecord& r : images_.take_all()) retire(std::move(r));
  retire_live_rejuvenated();
  reaper_.kill_retired();
  catch_up_.forget();  // the services start from their binaries: no generation to catch up to
  coordinator_.reset_timer();
  k.arm_timerfd();
  k.kernel_clock.begin_epoch();
  set_mode(SrMode::SC);  // safe, network off
  for (ServiceRuntime& s : k.services) {
    if (!s.config.rejuvenate || s.config.skip) continue;
    s.subscriptions.clear();
    s.config.params = build_params(k, s);  // boot.cold_restarts: the estimator starts from the sensors
    k.router.channel_opened(s);
    if (auto ok = k.supervisor.spawn_one(s); !ok) {
      k.stop_run(StopReason::ServiceFailed, "cold restart: " + ok.error().message);
      return;
    }
  }
  // Booted here, like at start (Kernel::boot), so that no step runs with half a graph. A service that does
  // not come up ends the run: there is nothing left to fall back to.
  const auto restarted = [&](const auto& pred) {
    return std::any_of(k.services.begin(), k.services.end(), [&](const ServiceRuntime& s) {
      return s.config.rejuvenate && !s.config.skip && pred(s);
    });
  };
  while (!k.stopping && restarted([](const ServiceRuntime& s) { return s.proc.booting(); })) {
    if (!k.pump(k.options.boot_deadline)) break;
  }
  coordinator_.drop_rollback();
  if (restarted([](const ServiceRuntime& s) { return s.proc.phase() != Phase::Ready; })) {
    k.stop_run(StopReason::ServiceFailed, "cold restart: a rejuvenated service did not boot");
  }
}

}  // namespace rejuv::kernel
