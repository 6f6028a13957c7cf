// The image coordinator's state (docs/design.md §7): what it has been asked to do, what it is doing, what the
// last checkpoint or rollback left behind, and the rejuvenation timer. One owner: every change is a
// transition below, which asserts that it is legal; the Rejuvenator holds it (rejuvenator.hpp), its
// procedures carry them out (rejuvenator.cpp, checkpoint.cpp, rollback.cpp), and the files that ask for them
// (channel_input.cpp, lockstep.cpp, kernel.cpp) go through the Rejuvenator's methods.
//
//   checkpoint   None ─ask→ Asked ─begin→ Running ─end→ None     Asked ─void_ask→ None (its caller is rolled back)
//                the alignment's untimed checkpoint (docs/design.md §6) is asked at most once per run (ask_priming)
//   rollback     None ─ask→ Asked ─take→ None                     a second ask keeps the first reason
//   abandoned    the last abandoned checkpoint and the services whose answer it had not read, until a commit
//   image work   None ─leave→ Left ─take→ None                    what a checkpoint or rollback left to do
//   timer        armed at most once per epoch (§V-C, Fig. 8: no recursive do_timer); spent by a rollback
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/image/image_store.hpp"

namespace rejuv::kernel {

// A checkpoint in progress (docs/design.md §7 "Checkpoint g"): the caller waits for its Reply; every rejuvenated
// service is asked for an image and answers Taken.
struct CheckpointRun {
  std::optional<ServiceId> caller{};  // none: the kernel's own (Kernel::checkpoint_now, the alignment's)
  std::uint32_t seq = 0;              // the caller's Invoke, answered when the generation is committed
  bool priming = false;               // the alignment's: neither timed, counted nor charged (docs/design.md §6)
  Nanos t_cp{0};                      // the cut (kernel clock): saved with the generation's state at the commit
  image::GenerationRecord record{};
  std::vector<ServiceId> waiting{};   // Snapshot sent, no Taken yet
  std::string failure{};              // the first reason the generation cannot be committed
};

// Why the stray sweep after a checkpoint or a rollback may wait for copies on their way (warden.cpp).
enum class SweepWait : std::uint8_t { No, ForCopies };

// The image work a checkpoint or a rollback leaves behind: the new generation's patches, the evicted
// generations, the stray sweep, the spare copies and the kill of retired incarnations. None of it is needed
// before the next checkpoint or rollback, and all of it takes CPU (forks, page copies, exits) that the
// vehicle's control chain needs right then: with a vehicle it waits until the first control update after the
// event has been routed (or kImageWorkWait of wall time), so that the chain's period holding the checkpoint or
// rollback is not also the one the image work runs in (rejuvenator.cpp, run_image_work).
struct ImageWork {
  std::optional<Generation> patches{};             // send_patches of this generation, then
  std::vector<image::GenerationRecord> evicted{};  // retire these (a base of the patches may be among them)
  std::string_view sweep{};                        // why the stray sweep is due
  SweepWait sweep_wait = SweepWait::No;            // ForCopies after a rollback (never in real time)
  std::optional<Generation> spares{};              // a spare copy of each image of this generation
};

class ImageCoordinator {
 public:
  enum class Checkpoint : std::uint8_t { None, Asked, Running };
  static constexpr Nanos kImageWorkWait{std::chrono::milliseconds{20}};

  // ---- checkpoint ----
  [[nodiscard]] Checkpoint checkpoint() const { return checkpoint_; }
  // Asked by `caller` (none: the kernel) in its Invoke `seq`; false (nothing changes) while one is asked or
  // running: one checkpoint at a time.
  bool ask_checkpoint(std::optional<ServiceId> caller, std::uint32_t seq) {
    if (checkpoint_ != Checkpoint::None) return false;
    ask_ = CheckpointRun{.caller = caller, .seq = seq};
    checkpoint_ = Checkpoint::Asked;
    return true;
  }
  // The alignment's checkpoint, asked once per run and only while nothing else is asked or running.
  bool ask_priming() {
    if (primed_ || checkpoint_ != Checkpoint::None || rollback_) return false;
    primed_ = true;
    ask_ = CheckpointRun{.priming = true};
    checkpoint_ = Checkpoint::Asked;
    return true;
  }
  // Who asked for the checkpoint that waits (Asked).
  [[nodiscard]] std::optional<ServiceId> asked_by() const {
    REJUV_ASSERT(checkpoint_ == Checkpoint::Asked, "no checkpoint is asked");
    return ask_.caller;
  }
  // The ask is void: its caller is about to be rolled back and nobody waits for the answer.
  void void_ask() {
    REJUV_ASSERT(checkpoint_ == Checkpoint::Asked, "no checkpoint is asked");
    ask_ = CheckpointRun{};
    checkpoint_ = Checkpoint::None;
  }
  // Asked → Running: the run of generation `g` cut at `t_cp`, with the ask's caller, seq and priming.
  CheckpointRun& begin_checkpoint(Generation g, Nanos t_cp) {
    REJUV_ASSERT(checkpoint_ == Checkpoint::Asked, "a checkpoint begins only when asked");
    checkpoint_ = Checkpoint::Running;
    ask_.t_cp = t_cp;
    ask_.record.g = g;
    return ask_;
  }
  // The checkpoint in progress (Running), or nullptr.
  [[nodiscard]] CheckpointRun* running() { return checkpoint_ == Checkpoint::Running ? &ask_ : nullptr; }
  [[nodiscard]] const CheckpointRun* running() const {
    return checkpoint_ == Checkpoint::Running ? &ask_ : nullptr;
  }
  // Running → None: the run, to be committed or abandoned.
  [[nodiscard]] CheckpointRun end_checkpoint() {
    REJUV_ASSERT(checkpoint_ == Checkpoint::Running, "no checkpoint is running");
    checkpoint_ = Checkpoint::None;
    return std::exchange(ask_, CheckpointRun{});
  }

  // ---- rollback ----
  [[nodiscard]] bool rollback_asked() const { return rollback_.has_value(); }
  // Carried out at the next safe point; a rollback already asked for keeps its reason.
  void ask_rollback(std::string reason) {
    if (!rollback_) rollback_ = std::move(reason);
  }
  // Asked → None: the reason, to be carried out now.
  [[nodiscard]] std::string take_rollback() {
    REJUV_ASSERT(rollback_.has_value(), "no rollback is asked");
    return *std::exchange(rollback_, std::nullopt);
  }
  // Asked → None without one: a cold restart has replaced every rejuvenated service meanwhile.
  void drop_rollback() { rollback_.reset(); }
  // A checkpoint or a rollback is asked (and waits for its safe point).
  [[nodiscard]] bool asked() const { return checkpoint_ == Checkpoint::Asked || rollback_; }

  // ---- the last abandoned checkpoint ----
  // An image taken for it that reports late is the kernel's own process, killed then (late_image) rather
  // than swept as a stray.
  void abandoned(Generation g, std::vector<ServiceId> waiting) {
    abandoned_ = g;
    owed_ = std::move(waiting);
  }
  // After a commit an image still owed to an abandoned checkpoint is a stray.
  void forget_abandoned() { owed_.clear(); }
  // Whether `s` still owes generation `g`'s answer to the abandoned checkpoint; if so it owes it no longer.
  bool settle_owed(Generation g, ServiceId s) {
    const auto it = std::find(owed_.begin(), owed_.end(), s);
    if (g != abandoned_ || it == owed_.end()) return false;
    owed_.erase(it);
    return true;
  }
  [[nodiscard]] bool owes(ServiceId s) const { return std::find(owed_.begin(), owed_.end(), s) != owed_.end(); }

  // ---- the image work left behind ----
  // Left until the next control update is routed or until `not_after` (wall clock); one at a time: the
  // procedures run what is left before they leave more.
  void leave_work(ImageWork work, Nanos not_after) {
    REJUV_ASSERT(!work_, "image work is run before the next checkpoint or rollback leaves more");
    work_ = std::move(work);
    work_not_after_ = not_after;
    control_update_routed_ = false;
  }
  [[nodiscard]] bool work_left() const { return work_.has_value(); }
  // The wall time by which the work left is due, if any.
  [[nodiscard]] std::optional<Nanos> work_deadline() const {
    return work_ ? std::optional<Nanos>(work_not_after_) : std::nullopt;
  }
  // An ActuatorOutputs was routed (watch.cpp): the work left is due.
  void control_update_routed() { control_update_routed_ = true; }
  [[nodiscard]] bool work_due(Nanos wall) const {
    return work_ && (control_update_routed_ || wall >= work_not_after_);
  }
  // Left → None: the work, to be run (or, at a cold restart or shutdown, its evicted generations retired).
  [[nodiscard]] std::optional<ImageWork> take_work() { return std::exchange(work_, std::nullopt); }

  // ---- the rejuvenation timer (docs/design.md §7–8): a kernel object, not part of any image ----
  [[nodiscard]] std::optional<Nanos> timer_due() const { return timer_.due; }
  [[nodiscard]] bool armed_in(Epoch epoch) const { return timer_.armed_in == epoch; }
  // Armed to fire at `due` and every `period` after it (0: once), at most once in `epoch`.
  void arm_timer(Epoch epoch, Nanos due, Nanos period) {
    REJUV_ASSERT(!armed_in(epoch), "the rejuvenation timer is armed at most once per epoch");
    timer_ = Timer{.due = due, .period = period, .armed_in = epoch};
  }
  // The timer fired: no longer due (a rollback follows, which rejuvenated() re-arms if periodic).
  void timer_fired() {
    REJUV_ASSERT(timer_.due.has_value(), "the rejuvenation timer was not due");
    timer_.due.reset();
  }
  // A rollback is the rejuvenation: a pending once-timer is spent; a periodic one runs on from `now`.
  void rejuvenated(Nanos now) {
    timer_.due = timer_.period > Nanos{0} ? std::optional<Nanos>(now + timer_.period) : std::nullopt;
  }
  // A cold restart: disarmed, and armable again.
  void reset_timer() { timer_ = Timer{}; }

 private:
  struct Timer {
    std::optional<Nanos> due{};
    Nanos period{0};                  // 0 = once
    std::optional<Epoch> armed_in{};  // the epoch of the last arm
  };

  Checkpoint checkpoint_ = Checkpoint::None;
  CheckpointRun ask_{};  // the ask (Asked) or the run (Running)
  bool primed_ = false;
  std::optional<std::string> rollback_{};
  Generation abandoned_{};          // the last abandoned checkpoint's generation
  std::vector<ServiceId> owed_{};   // its services whose answer it had not read
  std::optional<ImageWork> work_{};
  Nanos work_not_after_{0};
  bool control_update_routed_ = false;
  Timer timer_{};
};

}  // namespace rejuv::kernel
