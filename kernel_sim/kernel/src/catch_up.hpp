// Estimate catch-up after a rollback (launch sr.estimate_catch_up; docs/control.md §6.3). The paper's §VII
// names SR's cost as its open problem and "the estimation error from the time lapse between checkpoint and
// restore" as one cause: a restored estimator is a whole SR cycle old, and T_est waits for it to converge.
//
// The kernel keeps the samples that entered from the plant through the bridge on the topics the estimator chain
// reads — never what a service published, so a compromised `sensors` or `ekf2` cannot put anything in it — in
// a ring that outlives rollbacks (like the run's counters), with the position of each checkpoint's cut. When a
// rollback restores generation g, the samples since g's cut are replayed through the restored chain (the
// rejuvenated services that read them: sensors → ekf2) — in lockstep one sampling instant at a time with the
// graph idle in between (lockstep.cpp), in real time as fast as the chain's channels take it, ended once the
// chain answers a Sync with Idle (loop.cpp). Meanwhile a live sample queues behind the replay, and what the
// chain publishes for services outside it (vehicle_state for the controllers) is dropped: the controllers' next
// estimate is the live one, as fresh as a never-attacked estimator's.
//
// What the catch-up trusts, and how far (docs/control.md §6.3 "What the catch-up trusts"): the samples (the
// plant's, kept here) and the restored images' code; not the chain's speed nor what the chain makes of a replay.
// A replay ends at the kernel's own bound (kReplayBound, wall time since it began) whatever the chain does, and
// the estimator is then told to re-arm from the live samples (the paper's scheme, §IV: CATCH_UP_REARM) — never
// a fallback to an older generation, never a longer replay. The chain runs SCHED_OTHER from its restore until it
// has handled everything it was handed, so its real-time budget (RLIMIT_RTTIME) never counts replay work: a slow
// replay is no violation; slow live work is. The estimator tests the replayed estimate against the first live
// samples and discards it for a re-arm when it is implausible (ekf2_node.hpp); the kernel counts what it sees
// (Stats::discarded).
//
// One owner of the log, the cuts and the replay, held by the Rejuvenator (rejuvenator.hpp): the router keeps
// (router.cpp), the lockstep and the real-time loop replay (lockstep.cpp, loop.cpp), through the Rejuvenator's
// methods; the checkpoint cuts (checkpoint.cpp), the rollback begins (rollback.cpp), a cold restart forgets
// (there is nothing to catch up).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::kernel {

// VehicleStateEstimate.flags bit 3 (idl/state.idl; flight_io::kStateCatchUpDiscarded): the estimator discarded
// a replayed estimate and re-armed.
inline constexpr std::uint32_t kEstimateCatchUpDiscarded = 1U << 3U;

class CatchUp {
 public:
  // Which topics are logged and which services form the chain (create.cpp, plan_catch_up).
  struct Plan {
    std::vector<bool> logged;   // by ObjectId: bridged in from the plant and read by the chain
    std::vector<bool> cut_off;  // by ObjectId: published by the chain for services outside it
    std::vector<bool> chain;    // by ServiceId
    std::vector<bool> estimate;  // by ObjectId: the cut-off topics of type VehicleStateEstimate (its flags)
  };
  using Stats = CatchUpStats;
  enum class Begin : std::uint8_t { Replaying, NothingToReplay, NoLog };
  // The kernel's bound on a replay (wall time since it began). Real time: five control periods, so that the
  // controllers' estimate is never held back longer. Lockstep: the world is stopped meanwhile, so only the
  // plant's ack timeout (60 s) and the idle deadline (5 s, per instant) bound it; 1 s is well below both.
  static constexpr Nanos kReplayBoundRealtime{std::chrono::milliseconds{20}};
  static constexpr Nanos kReplayBoundLockstep{std::chrono::seconds{1}};

  CatchUp() = default;  // off: logs nothing, never replays
  // `capacity` samples of at most `slot_bytes` each, allocated here once.
  CatchUp(Plan plan, std::size_t capacity, std::size_t slot_bytes);

  [[nodiscard]] bool enabled() const { return capacity_ > 0; }
  [[nodiscard]] bool logs(ObjectId topic) const { return flag(plan_.logged, topic.value()); }
  [[nodiscard]] bool replaying() const { return replaying_; }
  // Cut short, and the chain may still be busy with the replay it was handed: it stays SCHED_OTHER until it has
  // answered Idle (drained()).
  [[nodiscard]] bool draining() const { return draining_; }
  void drained() { draining_ = false; }
  // The generation the replay in progress or the last one restored, and the stamp of its last replayed sample.
  [[nodiscard]] Generation generation() const { return generation_; }
  [[nodiscard]] std::uint64_t replayed_to() const { return replayed_to_; }
  // Replaying, and samples kept before the replay began are still to be handed on.
  [[nodiscard]] bool replay_pending() const { return replaying_ && replay_ != end_; }
  [[nodiscard]] bool in_chain(ServiceId service) const { return flag(plan_.chain, service.value()); }
  // `service` is of the chain and the replay is not over for it (replaying, or handling what it was handed):
  // it runs SCHED_OTHER and a slow answer is no hang until then.
  [[nodiscard]] bool in_replay(ServiceId service) const { return in_chain(service) && (replaying_ || draining_); }
  [[nodiscard]] const Stats& stats() const { return stats_; }

  // A sample from the plant on a logged topic: kept. True when it has to wait behind the replay in progress (the
  // replay hands it on in its turn); false when the caller routes it now.
  [[nodiscard]] bool keep(ObjectId topic, std::span<const std::byte> bytes, std::uint64_t stamp);
  // The checkpoint of generation g takes its cut now: its queue state holds every sample kept so far.
  void cut(Generation g);
  // A rollback restored g: the samples since g's cut are replayed (Replaying), there are none (NothingToReplay),
  // or some were overwritten or g's cut is not known (NoLog: the restored estimator stays a cycle old).
  // `wall`: when (the replay's real duration is measured from it).
  [[nodiscard]] Begin begin(Generation g, Nanos wall);
  [[nodiscard]] Nanos began_at() const { return began_at_; }
  [[nodiscard]] std::uint64_t replayed() const { return replayed_; }  // by the replay in progress or the last
  // Replaying: whether `publisher`'s publication on `topic` is held from the services outside the chain (and
  // counted).
  [[nodiscard]] bool drops(ServiceId publisher, ObjectId topic);
  // The next sampling instant (the samples kept next with one stamp, up to those kept when the replay began):
  // replay(topic, bytes) for each. When none is left the replay is over: the live samples that waited behind it
  // are handed to release(topic, bytes), in order, to be routed as live (they are kept already), and false is
  // returned.
  template <typename Replay, typename Release>
  [[nodiscard]] bool replay_instant(Replay&& replay, Release&& release) {
    if (!replaying_) return false;
    if (replay_ == end_) {
      release_waiting(release);
      return false;
    }
    const std::uint64_t stamp = entry(replay_).stamp;
    // The latest stamp replayed (a GPS sample is stamped when measured, gps_delay before it arrives).
    replayed_to_ = std::max(replayed_to_, stamp);
    do {
      replay(ObjectId{entry(replay_).topic}, bytes_of(replay_));
      ++replay_;
      ++replayed_;
      ++stats_.samples;
    } while (replay_ != end_ && entry(replay_).stamp == stamp);
    return true;
  }
  // Real time, the replay over its bound (a reader that does not keep up): the samples not handed on yet are
  // skipped (the estimator goes on as after lost samples), the live ones that waited are handed to
  // release(topic, bytes), and the chain's publications go to everyone again.
  template <typename Release>
  void cut_short(Release&& release) {
    if (!replaying_) return;
    ++stats_.cut_short;
    draining_ = true;
    release_waiting(release);
  }
  // Whether the replay in progress is past its bound at `wall`.
  [[nodiscard]] bool past_bound(Nanos wall, Nanos bound) const { return replaying_ && wall - began_at_ > bound; }
  // A publication of `publisher` on `topic` as routed: an estimate of the chain that says it discarded a replayed
  // estimate for a re-arm (flight_io kStateCatchUpDiscarded) is counted. The restored estimator's code is the
  // clean image's; a compromised one could only inflate a counter.
  void note_published(ServiceId publisher, ObjectId topic, std::span<const std::byte> bytes);
  // Real time: whether `service`, with `frames_issued` frames sent or on their way to it (FlowControl), still
  // needs a Sync to answer: none was issued after its last frame. Noted as issued when it does, so that a Sync
  // still waiting in the service's out-queue is not issued again.
  [[nodiscard]] bool sync_due(ServiceId service, std::uint64_t frames_issued) {
    if (synced_.size() <= service.value()) synced_.resize(service.value() + 1, 0);
    if (synced_[service.value()] == frames_issued) return false;
    synced_[service.value()] = frames_issued + 1;  // the Sync itself is one more frame
    return true;
  }
  // A cold restart: no generation is left to catch up to.
  void forget();

 private:
  struct Entry {
    std::uint32_t topic = 0;
    std::uint32_t size = 0;
    std::uint64_t stamp = 0;
  };
  struct Cut {
    Generation g{};
    std::uint64_t seq = 0;  // the first sample after the cut
  };
  static constexpr std::size_t kCutsKept = 8;  // more than any store keeps (launch keep_generations ≤ 4, + 1)

  [[nodiscard]] static bool flag(const std::vector<bool>& v, std::size_t i) { return i < v.size() && v[i]; }
  // The replay is over: the live samples that waited behind it go to release(topic, bytes), in order.
  template <typename Release>
  void release_waiting(Release&& release) {
    replaying_ = false;
    for (replay_ = end_; replay_ != next_; ++replay_) release(ObjectId{entry(replay_).topic}, bytes_of(replay_));
  }
  [[nodiscard]] const Entry& entry(std::uint64_t seq) const { return entries_[seq % capacity_]; }
  [[nodiscard]] std::span<const std::byte> bytes_of(std::uint64_t seq) const {
    return std::span<const std::byte>(arena_).subspan((seq % capacity_) * slot_bytes_, entry(seq).size);
  }

  Plan plan_{};
  std::size_t capacity_ = 0;
  std::size_t slot_bytes_ = 0;
  std::vector<Entry> entries_{};
  std::vector<std::byte> arena_{};
  // Samples are numbered from 0 in the order kept: [first_, next_) are in the ring, replay_ is the next to hand
  // on, end_ the first that came after the replay began (live: released when the replay is over).
  std::uint64_t first_ = 0;
  std::uint64_t next_ = 0;
  std::uint64_t replay_ = 0;
  std::uint64_t end_ = 0;
  bool replaying_ = false;
  bool draining_ = false;
  Generation generation_{};
  std::uint64_t replayed_to_ = 0;
  Nanos began_at_{0};
  std::uint64_t replayed_ = 0;
  std::vector<Cut> cuts_{};  // oldest first
  std::vector<std::uint64_t> synced_{};  // per service: its frames issued once its last Sync was
  Stats stats_{};
};

}  // namespace rejuv::kernel
