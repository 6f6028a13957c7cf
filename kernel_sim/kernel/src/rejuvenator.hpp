// The image coordinator of docs/design.md §7 as one owner (rejuvenator.cpp with the overview at its top,
// checkpoint.cpp, rollback.cpp, checkpointed_state.cpp): checkpoints, rollbacks, cold restarts, the image
// work they leave behind and the rejuvenation timer, carried out over the image store, the coordinator's
// state machine (image_coordinator.hpp), the routing freeze, the catch-up, the charge, the reaper and the
// channel pool — all of which it owns.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "catch_up.hpp"
#include "channel_pool.hpp"
#include "cpu_wait.hpp"
#include "image_charge.hpp"
#include "image_coordinator.hpp"
#include "link_guard.hpp"
#include "reaper.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/image/image_store.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/fd.hpp"
#include "routing_freeze.hpp"
#include "service_runtime.hpp"
#include "vehicle_pace.hpp"

namespace rejuv::kernel {

class Rejuvenator {
 public:
  explicit Rejuvenator(Kernel::Impl& kernel) : k(kernel) {}

  // Runs what is pending at a safe point (between routing rounds): a requested rollback, else a requested
  // checkpoint once the graph is quiescent. True when it did something.
  bool service_images();
  void request_rollback(std::string reason);
  void cold_restart(const std::string& reason);
  // The estimate catch-up's end (catch_up.hpp; rollback.cpp): `how` (CATCH_UP_DONE or CATCH_UP_REARM) told to the
  // estimator in a second rollback_signal of the epoch, ahead of the live samples.
  void signal_catch_up(rejuv_msg_EstimateCatchUp how);
  // Runs the loop until no checkpoint or rollback is pending (Kernel::checkpoint_now / rollback_now).
  [[nodiscard]] Result<void, KernelError> finish_image_requests();
  void arm_rejuvenation(ServiceRuntime& s, std::uint32_t seq, Nanos after, Nanos period);
  void fire_rejuvenation();  // the timer is due: roll back
  // Taken or TakenPages from `s`: whether the checkpoint in progress waits for it (no longer, once true).
  bool expecting_image(ServiceRuntime& s, const wire::FrameView& frame);
  void on_taken(ServiceRuntime& s, const wire::FrameView& frame);
  void on_taken_pages(ServiceRuntime& s, const wire::FrameView& frame, sys::UniqueFd pages);
  [[nodiscard]] bool knows_process(pid_t pid, const image::GenerationRecord* taking) const;
  void trim_images(bool now);  // the generation kept beyond K, once the newest K are confirmed
  void finish_retiring(bool final);
  // Whether the Patch `im` waits for may still come: its base's image, kept or retiring, has a copy.
  [[nodiscard]] bool patch_may_come(const image::Image& im) const;
  [[nodiscard]] std::uint64_t processes_to_spare() const;                  // the reaper's slack
  void set_mode(SrMode mode, std::optional<ServiceId> by = std::nullopt);  // enter_mode, sr_mode published
  // Observer::on_sr_event, stamped with now, the wall clock, the epoch and the mode (Figs. 7 and 8).
  void sr_event(SrEventKind kind, Generation g = {}, Nanos span = {},
                std::optional<ServiceId> by = std::nullopt);

  // What the SR scheme did (Kernel::sr_stats); the mission's t = 0, set once by create.cpp; the generations
  // waiting for their spare copies (the sandbox's sweep knows their pids).
  [[nodiscard]] const SrStats& sr_stats() const { return sr_stats_; }
  [[nodiscard]] Nanos flight_start() const { return flight_start_; }
  void set_flight_start(Nanos t) { flight_start_ = t; }
  [[nodiscard]] const std::vector<image::GenerationRecord>& retiring() const { return retiring_; }
  // The estimate catch-up's replay is over (Lockstep::replay_instant): the chain's real-time plan back, what it
  // took counted and, in lockstep, charged.
  void catch_up_done();
  // At shutdown: every generation, kept or left to evict, killed and reaped (docs/design.md §7).
  void release_all_images();
  // Set up by create.cpp: the store keeping `keep_generations`, the simulated time image work is charged, and
  // where in the control period it may start; the catch-up's plan and log (plan_catch_up).
  void set_up_image_work(std::size_t keep_generations, ImageCharge charge, VehiclePace pace) {
    images_ = image::ImageStore(keep_generations);
    image_charge_ = std::move(charge);
    pace_ = std::move(pace);
  }
  void set_up_catch_up(CatchUp catch_up) { catch_up_ = std::move(catch_up); }
  // Lockstep: what image work cost since the last step, charged to the plant's next one (image_charge.hpp).
  [[nodiscard]] Nanos take_step_charge() { return image_charge_.take_step_charge(); }
  // Real time with a vehicle: image work waiting for the slack after the next control update, until when.
  [[nodiscard]] std::optional<Nanos> image_work_wait_deadline() const { return pace_.wait_deadline(); }
  // The vehicle's controls were just routed at `wall` (MissionWatch): the image work left may run
  // (image_coordinator.hpp), and the control period's slack begins (vehicle_pace.hpp).
  void on_control_update(Nanos wall) {
    coordinator_.control_update_routed();
    pace_.on_control_update(wall);
  }
  // The links to other hosts of this kernel's part of the graph, made once at create (link_guard.hpp).
  void open_links();
  // Routing is frozen while a checkpoint or rollback is timed; a write to the plant meanwhile is held, and
  // written when routing resumes (resume_routing).
  [[nodiscard]] bool routing_frozen() const { return routing_.frozen(); }
  void hold_bridge_write(ObjectId topic, std::span<const std::byte> payload) { routing_.hold(topic, payload); }
  // The reaper (reaper.hpp): its slack sized once the services' limits are known (create.cpp); a stray child
  // killed and reaped off the critical path; whether a pid is one it reaps; at shutdown, all killed and reaped.
  void size_reaper() { reaper_.set_slack(processes_to_spare()); }
  void kill_and_reap_later(sys::ChildProcess p) { reaper_.kill(std::move(p)); }
  [[nodiscard]] bool reaping(pid_t pid) const { return reaper_.knows(pid); }
  // A copy of `service` the kernel asked for and let go of before it reported (image::UnheardCopies), if one
  // is left: taken, true (the sweep's unknown process in the service's session is that copy, not a stray).
  [[nodiscard]] bool take_unheard_copy(ServiceId service);
  void kill_and_reap_all() { reaper_.kill_all_and_reap(); }

  // The image store, the coordinator's state machine and the estimate catch-up, read by the other owners;
  // changed only by the Rejuvenator, the other owners asking through the methods below.
  [[nodiscard]] const image::ImageStore& images() const { return images_; }
  [[nodiscard]] const ImageCoordinator& coordinator() const { return coordinator_; }
  [[nodiscard]] const CatchUp& catch_up() const { return catch_up_; }
  // Reads the answers of the images' copies that have arrived, drops the dead copies (image::Image::refresh).
  void refresh_images() { images_.refresh_all(); }
  // A checkpoint asked by `caller` (none: the kernel) in its Invoke `seq`; false while one is asked or
  // running.
  bool request_checkpoint(std::optional<ServiceId> caller, std::uint32_t seq) {
    return coordinator_.ask_checkpoint(caller, seq);
  }
  // The alignment's untimed checkpoint (docs/design.md §6), asked once per run while nothing else is asked.
  bool request_priming() { return coordinator_.ask_priming(); }
  // The checkpoint in progress cannot be committed, for `why`: it is abandoned (checkpoint.cpp).
  void fail_checkpoint(std::string why) {
    CheckpointRun* const running = coordinator_.running();
    REJUV_ASSERT(running != nullptr, "no checkpoint is running");
    running->failure = std::move(why);
  }

  // ---- the estimate catch-up (catch_up.hpp): the Router keeps, the Lockstep and the loop replay ----
  // A plant sample on a logged topic, kept: true when it waits behind the replay in progress.
  [[nodiscard]] bool keep_plant_sample(ObjectId topic, std::span<const std::byte> bytes,
                                       std::uint64_t stamp) {
    return catch_up_.keep(topic, bytes, stamp);
  }
  // A service's publication as routed: an estimate that says it discarded a replayed one is counted.
  void note_publication(ServiceId publisher, ObjectId topic, std::span<const std::byte> bytes) {
    catch_up_.note_published(publisher, topic, bytes);
  }
  // Replaying: whether the chain's publication is held from the services outside it (and counted).
  [[nodiscard]] bool drops_publication(ServiceId publisher, ObjectId topic) {
    return catch_up_.drops(publisher, topic);
  }
  // The replay's next sampling instant handed to replay(topic, bytes); false once it is over, the live
  // samples that waited handed to release(topic, bytes) (CatchUp::replay_instant).
  template <typename Replay, typename Release>
  [[nodiscard]] bool replay_catch_up_instant(Replay&& replay, Release&& release) {
    return catch_up_.replay_instant(std::forward<Replay>(replay), std::forward<Release>(release));
  }
  // The replay past its bound: the rest skipped, the live samples that waited handed to
  // release(topic, bytes).
  template <typename Release>
  void cut_replay_short(Release&& release) {
    catch_up_.cut_short(std::forward<Release>(release));
  }
  // Real time: whether a chain service still needs a Sync after its last frame (noted as issued if so).
  [[nodiscard]] bool catch_up_sync_due(ServiceId service, std::uint64_t frames_issued) {
    return catch_up_.sync_due(service, frames_issued);
  }
  // After a cut: the chain has handled what it was handed, and its real-time plan is back.
  void catch_up_drained() {
    catch_up_.drained();
    chain_realtime();
  }

 private:
  image::ImageStore images_{2};
  ImageCoordinator coordinator_;  // the requests, the run, the work left, the timer (image_coordinator.hpp)
  CatchUp catch_up_;  // the plant's samples since each cut, replayed after a rollback (catch_up.hpp)
  ChannelPool channel_pool;  // socket pairs made ahead, fds closed after the timed part (channel_pool.hpp)

  // Generations out of the store whose spare copies have not all reported yet (their pids would otherwise
  // be unknown children): destroyed once they have (service_images).
  std::vector<image::GenerationRecord> retiring_;
  image::UnheardCopies unheard_;  // copies asked for by images let go of before they reported
  SrStats sr_stats_{};
  Nanos flight_start_{0};  // the end of the plant's alignment: the mission's t = 0

  // ---- rejuvenator.cpp ----
  static constexpr Nanos kTrimPeriod{std::chrono::milliseconds{2}};
  bool enter_mode(SrMode mode);  // the capability system's mode, on the time page; false (logged) if refused
  // When enter_mode last changed the mode: a Mode event's stamps. Between the links' close and open
  // (link_guard.hpp), so that the mode trace's secure interval never reaches past either.
  struct Stamp {
    Nanos t{0};     // kernel clock
    Nanos wall{0};  // wall clock
  };
  Stamp mode_changed_{};
  void retire(image::GenerationRecord record);
  void refill_pairs();  // channel_pool, for one checkpoint or rollback of every rejuvenated service
  // Opens the pagemap of every live incarnation that may take its next image by written pages (a service is
  // not dumpable and cannot open its own; the Snapshot hands it over). Off the critical paths, like
  // refill_pairs.
  void open_pagemaps();
  sys::SysResult<sys::UniqueFd> open_pagemap(ServiceRuntime& s);
  void resume_routing();
  void leave_image_work(ImageWork work);
  void run_image_work();           // now, whatever the trigger (also before a checkpoint or rollback)
  void image_work_if_due();        // the work left, after the vehicle's next control update
  void fire_rejuvenation_early();  // real time: due before the next control update, fired in this slack
  // How long the kernel waits for images: resume_deadline where the vehicle waits with it (real time,
  // measured charge), unseen_resume_deadline otherwise (KernelOptions).
  [[nodiscard]] Nanos image_wait_bound() const;
  // `seen` where the vehicle waits with the kernel's image work (real time, measured charge), else `unseen`.
  [[nodiscard]] Nanos wait_bound(Nanos seen, Nanos unseen) const;
  void settle_dying();  // backpressure on killed processes before a checkpoint or rollback

  // ---- checkpoint.cpp: the run's steps, the wall times of its timed part, the images ----
  struct CheckpointTimes {
    Nanos start{0}, sent{0}, taken{0}, saved{0};
  };
  [[nodiscard]] bool quiescent_for_checkpoint() const;
  void run_checkpoint();
  void send_snapshots(CheckpointRun& run);
  bool await_images(CheckpointRun& run);  // true: the deadline passed
  void answer_checkpoint(const CheckpointRun& run, std::int32_t error, std::uint64_t value);
  void abandon_checkpoint(CheckpointRun done, bool late, const CheckpointTimes& times);
  void commit_checkpoint(CheckpointRun done, CheckpointTimes times);
  void count_checkpoint(Generation g, std::optional<ServiceId> caller, const CheckpointTimes& times);
  // Whether a service of the checkpoint in progress died (sets its failure): the generation is abandoned.
  [[nodiscard]] bool lost_during(CheckpointRun& run) const;
  bool late_image(ServiceRuntime& s, const wire::FrameView& frame);
  // The base generation a Snapshot to `s` offers for an image by written pages (0: by fork).
  [[nodiscard]] Generation pages_base_for(const ServiceRuntime& s);
  // After a commit: has a copy of each base image make the new generation's images by written pages.
  void send_patches(image::GenerationRecord& record);

  // ---- rollback.cpp ----
  // The replay is over and the chain has handled what it was handed: its real-time plan back (it ran
  // SCHED_OTHER meanwhile, so that its RLIMIT_RTTIME never counted replay work).
  void chain_realtime();
  void run_rollback(const std::string& reason);
  // Resumes every image of `record` and restores its kernel state: the wall time its images were all back, or why
  // the generation is unusable (the caller retires whatever of it was resumed). Each image is waited for
  // until `wait`'s deadline, or on while what owes its answer waits for a CPU (cpu_wait.hpp).
  [[nodiscard]] Result<Nanos, std::string> resume_generation(image::GenerationRecord& record,
                                                             const CpuWait& wait);
  // A generation a rollback resumed: its record, and the wall time its images were all back.
  struct ResumedGeneration {
    image::GenerationRecord* record = nullptr;
    Nanos resumed_at{0};
  };
  // The newest generation whose images all come back (in real time first the one free_before_busy gives),
  // resumed; each newer one that does not (an image gone, or not answering by rollback_by, a fallback having
  // at least resume_deadline, or by max_cpu_wait of the bound since the rollback began while an image waits
  // for a CPU) retired on the way, counted as a fallback. Nothing if none comes back.
  [[nodiscard]] std::optional<ResumedGeneration> resume_newest_usable(Nanos rollback_by);
  // Real time only: when the newest generation is busy to resume (an image's copy still being made or
  // forking: ImageStore::free_to_resume), the newest older one that is not, if one is (rollback.cpp).
  [[nodiscard]] image::GenerationRecord* free_before_busy();
  [[nodiscard]] std::optional<ResumedGeneration> resume_or_retire(image::GenerationRecord& record,
                                                                  Nanos rollback_by);
  // Why `record` cannot be resumed without trying: the image of a service is gone (recorded as its violation).
  [[nodiscard]] std::optional<std::string> lost_image(image::GenerationRecord& record);
  void retire_live_rejuvenated();
  void announce_rollback(Generation g, Epoch epoch);  // the RollbackSignal and the SrMode, routing frozen

  Kernel::Impl& k;
  Nanos next_trim{0};  // wall clock: when trim_images looks again

  RoutingFreeze routing_;     // frozen while a checkpoint or rollback is timed (routing_freeze.hpp)
  Reaper reaper_;             // retired incarnations, killed processes not reaped yet (reaper.hpp)
  ImageCharge image_charge_;  // simulated time charged for image work (image_charge.hpp)
  VehiclePace pace_;          // where in the control period image work may start (vehicle_pace.hpp)
  // The links to other hosts, closed in the secure interval around each mode change (enter_mode; link_guard.hpp).
  LinkGuard links_{kernel_log(k), kernel_cgroups(k)};
};

}  // namespace rejuv::kernel
