// What the kernel knows about one service, by concern: each part names the file that writes it and the docs/design.md
// section it implements. Kernel::Impl::services holds one ServiceRuntime per service (impl.hpp), by ServiceId.
//
//   config         fixed at create (create.cpp): spec, driver level or rejuvenated, skipped, boot info, params
//   proc           the live incarnation (supervisor.cpp; images replace it in rollback.cpp): phase, process,
//                  channel and why it was lost
//   pages          the image base of the live incarnation, for images by written pages (checkpoint.cpp)
//   flow           delivery and flow control on its channel (router.cpp): the order of frames, the held frame,
//                  the control pool, the frame count that Idle reports, the per-step publication bound; read
//                  by every owner (flow()), written by the Router alone (the others tell it what happened)
//   sandbox        containment (warden.cpp): seccomp listener, output pipe, sessions, log rate limit
//   subscriptions  saved and restored with the images (channel_input.cpp, checkpointed_state.cpp)
//   stats          counters for Kernel::stats (every file counts its own; frames_out is flow's)
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fixed_ring.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/sys/cgroup.hpp"
#include "rejuv/sys/pagemap_agent.hpp"
#include "rejuv/broker/broker.hpp"
#include "rejuv/cap/cap_system.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/image/image_store.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/seccomp.hpp"

namespace rejuv::kernel {

inline constexpr std::size_t kOutQueueCapacity = 4096;    // pending deliveries per service
inline constexpr std::size_t kControlPoolCapacity = 256;  // queued non-ring frames per service
inline constexpr std::size_t kMaxStagedPerStep = 4096;    // publications per service per lockstep step

// Where a service is in its life.
enum class Phase : std::uint8_t {
  NotStarted,  // skipped, or not spawned yet
  Spawned,     // exec'd; waiting for Hello
  Booted,      // Boot…BootEnd sent; waiting for Ready
  Ready,       // running
  Dead,        // exited, killed or lost: reaped, channel closed
};

using SubscriptionRecord = image::SavedSubscription;  // saved with the images (docs/design.md §7 step 3)

// Token bucket for a service's log lines (docs/protocol.md: rate-limited per service).
struct LogLimiter {
  double tokens = 50;
  Nanos last{0};
  std::uint64_t suppressed_since_print = 0;
  [[nodiscard]] bool allow(Nanos wall_now);
};

// Fixed at create (create.cpp, from the launch graph and the policy; docs/design.md §2, §4). cold_restart (rollback.cpp)
// rebuilds `params` only.
struct ServiceConfig {
  const proto::ServiceSpec* spec = nullptr;
  bool rejuvenate = true;   // false = driver level (docs/design.md §2)
  bool skip = false;        // not started (KernelOptions::skip_services, or SR-only with SR off)
  std::string skip_reason{};
  std::string executable{};
  cap::BootInfo boot{};
  std::vector<wire::BootParam> params{};
  // The link between hosts (kernel_sim/policy hosts.hpp is_host_link; docs/sandbox.md "The link"): network-facing,
  // so it runs in its host's network namespace (`netns`, empty: the kernel's own) with the network allow-list and
  // may read its enclave; never rolled back, it is restarted from its binary when it is lost.
  struct HostLink {
    std::string netns;
    std::string enclave;
  };
  std::optional<HostLink> link{};
};

// The live incarnation (docs/design.md §2 "Processes and trust"). Its phase changes only through the
// transitions below, each of which asserts that it is legal: spawned by supervisor.cpp (or attached by
// scripted.cpp), booted and ready by channel_input.cpp (Hello, Ready), resumed from an image by rollback.cpp
// (docs/design.md §7 "Rollback"), ended by supervisor.cpp (lost, shut down) or rollback.cpp (retired).
//
//   NotStarted ─spawned→ Spawned ─booted→ Booted ─became_ready→ Ready
//        Dead ─spawned→ (a cold restart)         Dead ─resumed→ Ready (a rollback's restored image)
//   any started phase ─ended→ Dead
struct Incarnation {
  [[nodiscard]] Phase phase() const { return phase_; }
  void spawned() {
    REJUV_ASSERT(phase_ == Phase::NotStarted || phase_ == Phase::Dead, "spawned: the previous incarnation is live");
    phase_ = Phase::Spawned;
  }
  void booted() {
    REJUV_ASSERT(phase_ == Phase::Spawned, "booted: not waiting for Hello");
    phase_ = Phase::Booted;
  }
  void became_ready() {
    REJUV_ASSERT(phase_ == Phase::Booted, "ready: not booted");
    phase_ = Phase::Ready;
  }
  void resumed() {
    REJUV_ASSERT(phase_ == Phase::Dead, "resumed: the live incarnation was not retired first");
    phase_ = Phase::Ready;
  }
  void ended() {
    REJUV_ASSERT(phase_ != Phase::NotStarted, "ended: never started");
    phase_ = Phase::Dead;
  }

  sys::ChildProcess process{};
  sys::SeqPacket channel{};        // the kernel's end, non-blocking
  bool scripted = false;           // a test seam's socket pair, no process (Kernel::attach_scripted_services)
  Nanos spawned_at{0};             // wall clock
  std::optional<Nanos> channel_closed_at{};  // wall clock: the service closed fd 3 (its pidfd should follow)
  std::string loss_reason{};
  std::string last_error{};        // its last Error-level log line: named when it fails at boot (loop.cpp)

  [[nodiscard]] bool booting() const { return phase_ == Phase::Spawned || phase_ == Phase::Booted; }
  [[nodiscard]] bool live() const { return booting() || phase_ == Phase::Ready; }

 private:
  Phase phase_ = Phase::NotStarted;
};

// Images by written pages (docs/design.md §7; checkpoint.cpp): the generation the live incarnation's memory
// derives from (0: a fresh start), its /proc/<pid>/pagemap (open_pagemaps, rejuvenator.cpp) and whether a
// Snapshot has handed it over. Reset whenever a new process becomes the service (spawn_one,
// resume_generation); the agent outlives incarnations (it serves every process of one user namespace:
// rejuvenator.cpp open_pagemap).
struct WrittenPages {
  Generation base{};
  sys::UniqueFd pagemap{};
  bool pagemap_sent = false;
  bool pagemap_refusal_said = false;  // an open refused is logged once per service, not at every checkpoint
  sys::PagemapAgent agent{};          // without root: opens the pagemaps in the service's user namespace

  // A new process is this service: spawned (base 0) or resumed from generation `base`'s image.
  void start_incarnation(Generation from) {
    base = from;
    pagemap.reset();
    pagemap_sent = false;
  }
};

// A frame waiting to go out to a service: the next message of one of its subscriptions (the message itself
// stays in the broker's ring, docs/protocol.md "flow control"), or a queued non-ring frame.
struct OutEntry {
  enum class Kind : std::uint8_t { Ring, Control };
  Kind kind = Kind::Ring;
  broker::SubscriberId subscriber{};
  std::uint32_t control = 0;  // index into the control pool
};

// Delivery and flow control on one service's channel (docs/design.md §5; docs/protocol.md "Delivery and flow control"
// and "Idle"). Written by the Router alone (router.cpp, and the output batch it hands it to, output_batch.hpp);
// the channel itself is proc's.
// It keeps its own invariants:
// - order: a frame goes out at once only when nothing is held, queued or to sweep (drained()); otherwise it
//   waits behind, a ring entry in the out-queue, a control frame in the pool with its index in the out-queue.
//   Ring entries leave room for every control frame the pool can hold, so a Reply or a Shutdown always fits;
//   a full out-queue loses only the order of ring entries (the sweep drains every subscription), never messages.
// - the control pool: an index is taken when a frame is queued and given back when it has been sent.
// - Idle: frames_out counts every frame sent on the channel (Kernel::stats reports it); the service has
//   reported them all when its last Idle's count (since its channel was opened) plus frames_out at the opening
//   equals it. A frame counted and then refused by the channel is un-counted and counted again when it leaves.
class FlowControl {
 public:
  FlowControl() {
    pool_.reserve(kControlPoolCapacity);
    held_.reserve(wire::kMaxFrameBytes);
  }

  // Nothing held, queued or to sweep: a new frame may go out at once without overtaking any.
  [[nodiscard]] bool drained() const { return !has_held_ && queue_.empty() && !sweep_; }
  [[nodiscard]] std::size_t queued() const { return queue_.size(); }

  // ---- waiting frames ----
  // A ring message behind what waits already; when the out-queue has no room, the sweep takes it instead.
  void queue_ring(broker::SubscriberId subscriber) {
    if (queue_.size() + kControlPoolCapacity >= kOutQueueCapacity ||
        !queue_.push(OutEntry{.kind = OutEntry::Kind::Ring, .subscriber = subscriber, .control = 0})) {
      sweep_ = true;
    }
  }
  // A control frame behind what waits already (copied into the pool). Full: the service does not read its
  // channel (the caller treats it as hung, docs/protocol.md).
  enum class Queued : std::uint8_t { Yes, PoolFull, QueueFull };
  [[nodiscard]] Queued queue_control(std::span<const std::byte> frame) {
    std::uint32_t index = 0;
    if (!free_.empty()) {
      index = free_.back();
      free_.pop_back();
    } else if (pool_.size() < kControlPoolCapacity) {
      index = static_cast<std::uint32_t>(pool_.size());
      pool_.emplace_back();
    } else {
      return Queued::PoolFull;
    }
    pool_[index].assign(frame.begin(), frame.end());
    if (!queue_.push(OutEntry{.kind = OutEntry::Kind::Control, .subscriber = {}, .control = index})) {
      free_.push_back(index);
      return Queued::QueueFull;
    }
    return Queued::Yes;
  }
  // Takes the oldest waiting entry: a ring subscriber goes to `ring(subscriber)`, a control frame to
  // `control(bytes)`, its pool entry given back once that returns. False when nothing waits.
  template <class Ring, class Control>
  bool pop(Ring&& ring, Control&& control) {
    if (queue_.empty()) return false;
    const OutEntry e = queue_.pop();
    switch (e.kind) {
      case OutEntry::Kind::Ring: ring(e.subscriber); break;
      case OutEntry::Kind::Control:
        control(std::span<const std::byte>(pool_[e.control]));
        free_.push_back(e.control);
        break;
    }
    return true;
  }
  // The sweep: every subscription drained once the out-queue is empty (after an overflow, or a resumed routing).
  void request_sweep() { sweep_ = true; }
  [[nodiscard]] bool sweeping() const { return sweep_; }
  // Whether a sweep was requested; it is no longer (request it again if the channel blocks during it).
  [[nodiscard]] bool take_sweep() {
    const bool was = sweep_;
    sweep_ = false;
    return was;
  }

  // ---- the held frame: the one the channel refused (EAGAIN), sent first when it drains ----
  void hold(std::span<const std::byte> frame) {
    held_.assign(frame.begin(), frame.end());
    has_held_ = true;
  }
  [[nodiscard]] bool has_held() const { return has_held_; }
  [[nodiscard]] std::span<const std::byte> held() const { return held_; }
  void held_sent() {  // it left: counted, and no longer held
    ++frames_out_;
    has_held_ = false;
  }

  // ---- polled subscriptions (docs/protocol.md): news handed over ahead of the next frame that wakes it ----
  void note_polled() { polled_pending_ = true; }
  [[nodiscard]] bool take_polled() {
    const bool was = polled_pending_;
    polled_pending_ = false;
    return was;
  }

  // Whether the kernel waits for the channel to drain (epoll writable interest). True when `want` changes it.
  [[nodiscard]] bool want_writable() const { return want_writable_; }
  [[nodiscard]] bool set_want_writable(bool want) {
    if (want_writable_ == want) return false;
    want_writable_ = want;
    return true;
  }

  // ---- the frame count (docs/protocol.md "Idle") ----
  void count_sent() { ++frames_out_; }
  void uncount(std::uint64_t frames) { frames_out_ -= frames; }
  void on_idle(std::uint64_t frames_received) { idle_count_ = frames_received; }
  // A new channel (a spawn, a restored image: docs/design.md §7): the service's count restarts at 0.
  void new_channel() {
    idle_count_ = 0;
    frames_base_ = frames_out_;
  }
  [[nodiscard]] std::uint64_t frames_out() const { return frames_out_; }
  // Frames sent or on their way (held, or waiting in the out-queue): a frame moves from waiting to sent without
  // changing it; a new frame, or one a sweep sends, adds to it.
  [[nodiscard]] std::uint64_t frames_issued() const {
    return frames_out_ + queue_.size() + (has_held_ ? 1U : 0U);
  }
  [[nodiscard]] std::uint64_t reported() const { return idle_count_ + frames_base_; }
  [[nodiscard]] bool reported_all() const { return reported() == frames_out_; }

  // ---- the publications a service may stage in one lockstep step (router.cpp ingest_publish) ----
  [[nodiscard]] bool admit_publication() {
    if (staged_this_step_ >= kMaxStagedPerStep) return false;
    ++staged_this_step_;
    return true;
  }
  void new_step() { staged_this_step_ = 0; }

  // The channel is gone (a death, a retired incarnation): nothing waits, nothing is held. The count stays.
  void reset() {
    queue_.clear();
    has_held_ = false;
    want_writable_ = false;
    sweep_ = false;
    polled_pending_ = false;
    pool_.clear();
    free_.clear();
  }

 private:
  FixedRing<OutEntry> queue_{kOutQueueCapacity};
  bool sweep_ = false;           // the out-queue overflowed: drain every subscription once it empties
  bool polled_pending_ = false;  // a polled subscription has news, handed over at the next wake-up
  std::vector<std::vector<std::byte>> pool_{};
  std::vector<std::uint32_t> free_{};
  std::vector<std::byte> held_{};
  bool has_held_ = false;
  bool want_writable_ = false;
  std::uint64_t frames_out_ = 0;   // frames sent on the channel (ServiceStats::frames_out)
  std::uint64_t idle_count_ = 0;   // the count in the service's last Idle
  std::uint64_t frames_base_ = 0;  // frames_out_ when its channel was opened
  std::uint64_t staged_this_step_ = 0;
};

// Containment (warden.cpp, docs/design.md §7 "Protection"; docs/sandbox.md): the listener of its seccomp
// filter (shared by every process of the service), the read end of the pipe on its fds 1-2 and its unfinished
// last line, the session ids of its incarnations spawned so far, the rate limit of what it may log
// (loop.cpp), and its cgroup (made at its first spawn; empty where the machine refuses one — cgroup_note says
// why).
struct Containment {
  sys::ServiceCgroup cgroup{};
  std::string cgroup_note{};
  std::uint64_t oom_kills_seen = 0;  // the live leaf's OOM kills already counted (Warden::count_out_of_memory)
  sys::SeccompListener seccomp{};
  sys::UniqueFd output{};
  std::string output_partial{};
  std::vector<pid_t> sessions{};
  LogLimiter limiter{};
};

// Everything the kernel knows about one service.
struct ServiceRuntime {
  ServiceId id{};      // its policy declaration order = its CSpace (create.cpp)
  std::string name{};
  ServiceConfig config{};
  Incarnation proc{};
  WrittenPages pages{};
  Containment sandbox{};
  std::vector<SubscriptionRecord> subscriptions{};
  ServiceStats stats{};  // frames_out is flow's (Kernel::stats fills it in)
  std::vector<std::uint64_t> published{};  // accepted publications by object id, one per object (create.cpp)

  [[nodiscard]] bool live() const { return proc.live(); }
  // Lockstep (docs/protocol.md "Idle"): it has reported every frame sent to it and nothing waits for it.
  [[nodiscard]] bool idle() const {
    return proc.phase() != Phase::Ready || proc.scripted || (flow_.reported_all() && flow_.drained());
  }
  [[nodiscard]] const FlowControl& flow() const { return flow_; }

 private:
  friend class Router;  // the one writer of flow_
  FlowControl flow_{};
};

}  // namespace rejuv::kernel
