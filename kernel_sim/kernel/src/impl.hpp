// The kernel's private state, shared by the files of kernel_sim/kernel/src (kernel.hpp lists them): the
// services (one ServiceRuntime each, by concern: service_runtime.hpp), the objects and subscribers, the lockstep
// staging state, the clock, the image coordinator's state (DESIGN §7), the DDS bridge and the loop.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "bridge.hpp"
#include "canonical_stage.hpp"
#include "catch_up.hpp"
#include "channel_pool.hpp"
#include "image_charge.hpp"
#include "image_coordinator.hpp"
#include "invocation.hpp"
#include "kernel_clock.hpp"
#include "step_clock.hpp"
#include "mission_watch.hpp"
#include "netgate.hpp"
#include "output_batch.hpp"
#include "reaper.hpp"
#include "routing_freeze.hpp"
#include "vehicle_pace.hpp"
#include "rejuv/broker/broker.hpp"
#include "rejuv/cap/cap_system.hpp"
#include "rejuv/channel/codes.hpp"
#include "rejuv/channel/transport.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/clock/time_page.hpp"
#include "rejuv/clock/timers.hpp"
#include "rejuv/image/image_store.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/policy/policy.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/lease.hpp"
#include "rejuv/sys/seccomp.hpp"
#include "service_runtime.hpp"

namespace rejuv::kernel {

inline constexpr Nanos kChannelCloseGrace{std::chrono::seconds{1}};  // closed fd 3 but still running: lost
inline constexpr std::size_t kFramesPerWakeup = 64;          // fairness: frames read per channel per wakeup
inline constexpr std::uint32_t kNoOrigin = 0xFFFF'FFFFU;     // the kernel / the DDS bridge

// Per kernel object: what routing needs (types, kernel endpoints, bridge, mission watch).
struct ObjectInfo {
  ObjectId id{};
  std::string name{};
  ObjectKind kind = ObjectKind::Topic;
  const msgs::TopicType* type = nullptr;  // topics only
  policy::KernelEndpoint kernel = policy::KernelEndpoint::None;
  bool is_setpoint = false;               // watched for mission_done (rejuv::msg::Setpoint)
  bool is_actuator_outputs = false;       // a control update (Fig. 7): Observer::on_control_update
  std::vector<std::byte> persistent{};    // Persistent cells (survive rollback, DESIGN §3)
  std::vector<std::byte> limits{};        // Limits: the last LimitsWrite data
};

// Lockstep: a publication read from a service during a routing round, routed at the end of the round in
// canonical order (publisher id, then arrival); a DDS sample held for its step, routed by (timestamp, reader).
// Publications: key the publisher's ServiceId value, tag the slot. Samples: key (timestamp, reader), no tag.
using PublicationStage = CanonicalStage<std::uint32_t, std::uint32_t>;
using SampleStage = CanonicalStage<std::pair<std::uint64_t, std::uint32_t>, std::monostate>;

enum class Source : std::uint8_t {
  Channel = 1, Pidfd = 2, Signal = 3, Timer = 4, Dds = 5, Plant = 6, Net = 7, Seccomp = 8, Output = 9
};
[[nodiscard]] constexpr std::uint64_t token(Source s, std::uint64_t index) {
  return (static_cast<std::uint64_t>(s) << 56U) | index;
}

struct Kernel::Impl {
  // ---- configuration ----
  launch::LoadedLaunch graph;
  KernelOptions options;
  Observer* observer = nullptr;
  policy::Policy policy;
  ClockMode clock_mode = ClockMode::Lockstep;
  bool sr = false;
  std::uint64_t seed = 1;
  std::uint32_t domain = 0;
  std::optional<int> pinned_cpu;  // KernelOptions::placement: the CPU of the whole run, if pinned

  // ---- components ----
  cap::CapSystem caps;
  broker::Broker broker;
  KernelClock kernel_clock;                              // the time page's one writer (kernel_clock.hpp)
  clock::TimerTable timers;
  std::optional<sys::SeccompProgram> seccomp;
  std::optional<sys::SignalFd> signals;
  sys::Epoll epoll;
  std::optional<sys::TimerFd> timerfd;
  std::optional<DdsBridge> bridge;                 // DDS, and the plant's lockstep adapter (bridge.hpp)
  NetGate net;                                     // the external link's UDP socket (netgate.cpp)
  OutputBatch batch;                               // a lockstep round's output (router.cpp, cork/uncork)

  std::vector<msgs::TopicType> declared_types;     // the policy's own (`types`), pointed to by objects
  std::vector<ObjectInfo> objects;                 // by ObjectId
  std::vector<ServiceRuntime> services;            // by ServiceId
  // By SubscriberId value: whose subscription it is, its slot, and how many messages were routed to it
  // (routed − delivered − pending = lost, counted even while it stays blocked and never calls next()).
  struct SubscriberInfo {
    ServiceId service{};
    Slot slot{};
    std::uint64_t routed = 0;
    bool polled = false;  // wire::kSubscribePolled
  };
  std::vector<SubscriberInfo> subscribers;

  // ---- plant ----
  sys::ChildProcess plant;
  bool plant_started = false;

  // ---- lockstep ----
  StepClock steps;               // the queue, the active step, its rounds and deadlines (step_clock.hpp)
  bool samples_on_step = false;  // sample readers are not in epoll: taken when a SimStep arrives
  bool watching_samples = false;
  void report_stall();           // supervisor.cpp: no step completed for kStallReportAfter
  PublicationStage staged;       // a round's publications (router.cpp, canonical_stage.hpp)
  SampleStage samples;           // the samples of the step (lockstep.cpp stages, router.cpp routes)

  // ---- the image coordinator's state (images.cpp, checkpoint.cpp, rollback.cpp; DESIGN §7) ----
  image::ImageStore images{2};
  ImageCoordinator coordinator;  // the requests, the run, the work left, the timer (image_coordinator.hpp)
  RoutingFreeze routing;  // frozen while a checkpoint or rollback is timed (routing_freeze.hpp)
  CatchUp catch_up;       // the plant's samples since each cut, replayed after a rollback (catch_up.hpp)
  SrStats sr_stats{};
  ImageCharge image_charge;                 // simulated time charged for image work (image_charge.hpp)
  VehiclePace pace;                         // where in the control period image work may start (vehicle_pace.hpp)
  Nanos flight_start{0};                    // the end of the plant's alignment: the mission's t = 0
  // The untimed checkpoint of the alignment that forks every service's first image (DESIGN §6): asked for at
  // the first step, carried out as any checkpoint but neither timed, counted nor charged.
  void request_priming();
  Reaper reaper;  // retired incarnations, killed processes not reaped yet (reaper.hpp)
  // As root, service i runs as sys::service_uid(*uid_block, i), from a block this kernel alone holds.
  std::optional<sys::Lease> uid_block;
  ChannelPool channel_pool;  // socket pairs made ahead, fds closed after the timed part (channel_pool.hpp)
  // Generations out of the store whose spare copies have not all reported yet (their pids would otherwise
  // be unknown children): destroyed once they have (images.cpp, service_images).
  std::vector<image::GenerationRecord> retiring;
  static constexpr Nanos kTrimPeriod{std::chrono::milliseconds{2}};
  Nanos next_trim{0};                   // wall clock: when trim_images looks again
  void trim_images(bool now);           // the generation kept beyond K, once the newest K are confirmed
  void retire(image::GenerationRecord record);
  void finish_retiring(bool final);
  void refill_pairs();  // channel_pool, for one checkpoint or rollback of every rejuvenated service
  // Opens the pagemap of every live incarnation that may take its next image by written pages (a service is
  // not dumpable and cannot open its own; the Snapshot hands it over). Off the critical paths, like refill_pairs.
  void open_pagemaps();

  // ---- run state ----
  bool booted = false;
  bool shut_down = false;
  bool stopping = false;
  std::optional<StopReason> stop;
  std::string stop_detail;
  bool sr_mode_announced = false;
  MissionWatch mission;  // watch.cpp
  Nanos run_start_mono{0};
  bool clock_synced = true;  // realtime with a plant: the kernel clock follows the plant's from its first sample
  Nanos wall_start{0};
  Nanos last_progress{0};
  std::uint64_t denials_drained = 0;
  std::uint64_t kernel_bad_frames = 0;
  // read_channel: one frame slot per recvmmsg entry (8-byte aligned slots: the wire layouts need it).
  alignas(8) std::array<std::byte, wire::kMaxFrameBytes * sys::kMaxReceiveBatch> rx_batch{};
  wire::FrameBuffer tx;          // control frames (Reply, TimerFired, Boot …), passed to send_control
  wire::FrameBuffer deliver_tx;  // Deliver frames (deliver_one), which may go out while a control frame is in tx

  Impl(launch::LoadedLaunch g, KernelOptions o, Observer* obs, policy::Policy p, cap::CapSystem c, broker::Broker b,
       clock::TimePageWriter tp, std::size_t service_count, sys::Epoll e)
      : graph(std::move(g)), options(std::move(o)), observer(obs), policy(std::move(p)), caps(std::move(c)),
        broker(std::move(b)), kernel_clock(std::move(tp), caps.mode()), timers(service_count), epoll(std::move(e)) {}

  // ---- logging (loop.cpp) ----
  void log(const char* format, ...) __attribute__((format(printf, 2, 3)));
  void service_log(ServiceRuntime& s, wire::LogLevel level, std::string_view text);
  void refuse(ServiceRuntime& s, std::string_view what);  // counts and logs (rate-limited) a bad frame

  // ---- time (loop.cpp) ----
  [[nodiscard]] Nanos now() const { return kernel_clock.now(); }
  void set_now(Nanos t);  // the kernel clock and the capability system's time
  [[nodiscard]] Nanos wall() const;
  void stop_run(StopReason reason, std::string detail);

  // ---- boot and supervision (supervisor.cpp) ----
  [[nodiscard]] Result<void, KernelError> spawn_all();
  [[nodiscard]] Result<void, KernelError> spawn_one(ServiceRuntime& s);
  [[nodiscard]] Result<void, KernelError> spawn_plant();
  void send_boot(ServiceRuntime& s);
  void on_child_exit(ServiceRuntime& s);
  void on_plant_exit();
  // The one place a service is lost (death, hang, protocol fault). With SR a rejuvenated service's loss asks
  // for a rollback (DESIGN §7); before the graph has booted, without SR, or for a driver-level service the run ends.
  void lose_service(ServiceRuntime& s, std::string reason);
  void kill_hung(ServiceRuntime& s, std::string reason);
  void check_deadlines();
  void shutdown_all();

  // ---- containment (sandbox.cpp, DESIGN §7 "Protection") ----
  enum class Violation : std::uint8_t { ForbiddenCall, StrayProcess, ImageLost };
  // Calls the filter referred to the kernel: boot calls continue while the service boots; anything else
  // kills the caller and counts a violation.
  void on_seccomp_notice(ServiceRuntime& s);
  // Lines the service wrote on fds 1-2, logged under its name (rate-limited, control characters escaped).
  void on_service_output(ServiceRuntime& s, bool final = false);
  // Kills every process of a service's session that is neither its live incarnation nor an image the kernel
  // knows (strays): at every commit, after every rollback, about once a simulated second, and at shutdown.
  // Deferred while copies the kernel asked for are on their way (their pids are not known yet).
  // After a rollback it first waits (briefly, off the critical path) for copies asked for earlier, so that no
  // stray outlives the rollback (ForCopies); elsewhere a service with a copy on its way is swept next time.
  void sweep_strays(std::string_view when, bool final = false, SweepWait wait = SweepWait::No);
  void sweep_if_due();  // at a safe point off the critical paths: sweep_due, or a simulated second since the last
  void record_violation(ServiceRuntime& s, Violation kind, std::string_view what);
  void close_sandbox(ServiceRuntime& s);  // listener and output pipe, out of epoll
  void join_cgroup(ServiceRuntime& s);    // makes the service's cgroup at its first spawn (or notes why not)
  // A restored incarnation's new stdout/stderr pipe: what the old one still holds is logged, then it is
  // closed and the new one watched.
  [[nodiscard]] sys::SysResult<void> replace_output(ServiceRuntime& s, sys::UniqueFd read_end);
  [[nodiscard]] sys::ResourceLimits limits_for(const ServiceRuntime& s) const;
  std::optional<std::string_view> sweep_due;  // why a sweep is wanted (a commit, a rollback, a violation)
  Nanos last_sweep{0};                        // kernel clock

  // ---- the real-time plan (realtime.cpp; idl/launch.proto RealtimePlan; docs/realtime.md) ----
  bool realtime_active = false;  // the plan is on and the kernel was granted SCHED_FIFO
  void start_realtime_plan();              // run_realtime: the kernel's threads and memory, the plant, the Ready
  void apply_realtime(ServiceRuntime& s);  // a service that became Ready (spawned, cold-restarted or restored)

  // ---- images (the image coordinator: images.cpp, checkpoint.cpp, rollback.cpp; overview in images.cpp) ----
  // Runs what is pending at a safe point (between routing rounds): a requested rollback, else a requested
  // checkpoint once the graph is quiescent. True when it did something.
  bool service_images();
  [[nodiscard]] bool quiescent_for_checkpoint() const;
  void run_checkpoint();
  // Its steps (checkpoint.cpp): the wall times of the timed part, the Snapshots, the wait for every image
  // (true: the deadline passed), and the end, abandoned or committed (and, unless the alignment's, counted).
  struct CheckpointTimes {
    Nanos start{0}, sent{0}, taken{0}, saved{0};
  };
  void send_snapshots(CheckpointRun& run);
  bool await_images(CheckpointRun& run);
  void answer_checkpoint(const CheckpointRun& run, std::int32_t error, std::uint64_t value);
  void abandon_checkpoint(CheckpointRun done, bool late, const CheckpointTimes& times);
  void commit_checkpoint(CheckpointRun done, CheckpointTimes times);
  void count_checkpoint(Generation g, std::optional<ServiceId> caller, const CheckpointTimes& times);
  // Whether a service of the checkpoint in progress died (sets its failure): the generation is abandoned.
  [[nodiscard]] bool lost_during(CheckpointRun& run) const;
  // Taken or TakenPages from `s`: whether the checkpoint in progress waits for it (no longer, once true).
  bool expecting_image(ServiceRuntime& s, const wire::FrameView& frame);
  bool late_image(ServiceRuntime& s, const wire::FrameView& frame);
  [[nodiscard]] bool knows_process(pid_t pid, const image::GenerationRecord* taking) const;
  void on_taken(ServiceRuntime& s, const wire::FrameView& frame);
  void on_taken_pages(ServiceRuntime& s, const wire::FrameView& frame, sys::UniqueFd pages);
  // The base generation a Snapshot to `s` offers for an image by written pages (0: by fork).
  [[nodiscard]] Generation pages_base_for(const ServiceRuntime& s);
  // After a commit: has a copy of each base image make the new generation's images by written pages.
  void send_patches(image::GenerationRecord& record);
  // The image work a checkpoint or rollback leaves behind (ImageWork): run after the vehicle's next control
  // update, or at once without a plant.
  void leave_image_work(ImageWork work);
  void run_image_work();               // now, whatever the trigger (also before a checkpoint or rollback)
  void image_work_if_due();
  void request_rollback(std::string reason);
  void run_rollback(const std::string& reason);
  // Resumes every image of `record`; false (and everything resumed killed again) if one fails.
  bool resume_generation(image::GenerationRecord& record, Nanos deadline, std::string& failure, Nanos& resumed_at);
  // How long the kernel waits for images: resume_deadline where the vehicle waits with it (real time,
  // measured charge), unseen_resume_deadline otherwise (KernelOptions).
  [[nodiscard]] Nanos image_wait_bound() const;
  void settle_dying();  // images.cpp: backpressure on killed processes before a checkpoint or rollback
  [[nodiscard]] std::uint64_t processes_to_spare() const;  // images.cpp: the reaper's slack
  void cold_restart(const std::string& reason);
  void resume_routing();
  // Runs the loop until no checkpoint or rollback is pending (Kernel::checkpoint_now / rollback_now).
  [[nodiscard]] Result<void, KernelError> finish_image_requests();
  void retire_live_rejuvenated();
  void arm_rejuvenation(ServiceRuntime& s, std::uint32_t seq, Nanos after, Nanos period);
  void fire_rejuvenation();  // the timer is due: roll back
  void fire_rejuvenation_early();  // real time: due before the next control update, fired in this slack
  void set_mode(SrMode mode, std::optional<ServiceId> by = std::nullopt);  // enter_mode, sr_mode published
  // The capability system's mode, shown on the time page; false (logged) if the policy refuses it.
  bool enter_mode(SrMode mode);
  // Observer::on_sr_event, stamped with now, the wall clock, the epoch and the mode (Figs. 7 and 8).
  void sr_event(SrEventKind kind, Generation g = {}, Nanos span = {}, std::optional<ServiceId> by = std::nullopt);

  // ---- channel input (requests.cpp) ----
  void read_channel(ServiceRuntime& s);
  // The frames of one datagram read from the service's channel (no fd): handled one by one until one does
  // not decode (the rest of its datagram is refused with it) or the service is lost.
  void receive_datagram(ServiceRuntime& s, std::span<const std::byte> datagram);
  void handle_frame(ServiceRuntime& s, const wire::FrameView& frame);
  void handle_hello(ServiceRuntime& s, const wire::FrameView& frame);  // Boot sent; Phase::Booted
  void handle_ready(ServiceRuntime& s);                                // Phase::Ready, the real-time plan
  void handle_timer_arm(ServiceRuntime& s, const wire::FrameView& frame);
  void handle_log(ServiceRuntime& s, const wire::FrameView& frame);
  void handle_subscribe(ServiceRuntime& s, const wire::FrameView& frame);
  // Invoke (invocation.hpp): decoded per object kind, the authority checked, then invoked on its owner.
  void handle_invoke(ServiceRuntime& s, const wire::FrameView& frame);
  [[nodiscard]] bool provides(ObjectKind kind) const;  // the Checkpoint kind only with SR
  // Answers an Invoke with an error; a refused NetSend is counted by the gate (NetStats::send_refused).
  void refuse_invoke(ServiceRuntime& s, std::uint32_t seq, cap::Operation op, std::int32_t code);
  void invoke_checkpoint(ServiceRuntime& s, std::uint32_t seq, const CheckpointInvocation& c);
  void invoke_limits(ServiceRuntime& s, std::uint32_t seq, ObjectInfo& o, const LimitsInvocation& l);
  void invoke_persistent(ServiceRuntime& s, std::uint32_t seq, ObjectInfo& o, const PersistentInvocation& p);
  void reply(ServiceRuntime& s, std::uint32_t seq, std::int32_t error, std::uint64_t value = 0,
             std::span<const std::byte> data = {});

  // ---- observers of the routed traffic (watch.cpp, mission_watch.hpp) ----
  // The one hook of the routing core: every publication routed, the service's or the kernel's own.
  void watch_publication(const ObjectInfo& o, std::span<const std::byte> payload, broker::TopicGeneration g,
                         std::optional<ServiceId> publisher);
  void drain_denials();  // the capability system's new denials: counted, logged, published as SecurityEvents

  // ---- routing (router.cpp) ----
  void ingest_publish(ServiceRuntime& s, std::uint32_t slot, std::span<const std::byte> payload);
  void route_publish(ServiceRuntime& s, std::uint32_t slot, std::span<const std::byte> payload);
  // Who published: the kernel's own topics go out through the bridge, samples that came in do not.
  // Bridge: a plant sample; Replay: a plant sample the catch-up hands on again (not watched twice); Held: a
  // plant sample that waited behind a replay (kept already). None of them goes back out to the plant.
  enum class From : std::uint8_t { Service, Kernel, Bridge, Replay, Held };
  void publish_as_kernel(ObjectId topic, std::span<const std::byte> payload, From from = From::Kernel);
  // A message of the kernel's own (SrMode, RollbackSignal, SecurityEvent) on every topic of its type that the
  // policy says the kernel publishes (KERNEL_PUBLISHES; none: not published). The one place that finds them.
  template <typename T>
  void publish_kernel_message(const T& message) {
    for (const ObjectInfo& o : objects) {
      if (o.type != nullptr && o.type->name == msgs::TopicTraits<T>::name &&
          o.kernel == policy::KernelEndpoint::Publishes) {
        publish_as_kernel(o.id, std::as_bytes(std::span(&message, 1)));
      }
    }
  }
  void after_publish(ObjectId topic, std::span<const std::byte> payload, broker::TopicGeneration g,
                     std::optional<ServiceId> publisher, From from);
  void finish_routes(ObjectId topic);  // pushes the topic's newest message to every subscriber
  void flush_staged();
  void route_samples();
  // Lockstep, the graph idle: the catch-up's next sampling instant routed as a round of its own; at its end,
  // what it cost charged (catch_up.hpp, lockstep.cpp).
  void replay_next_instant();
  // Real time (loop.cpp): the replay handed on a few instants at a time while the chain's channels keep up, then
  // ended once the chain has handled it all (Sync → Idle; its outputs held from the others until then).
  void pace_catch_up();
  bool replay_instant();  // the next instant, or the end of the replay (false): measured and charged
  void publish_sr_mode();
  bool write_to_bridge(ObjectId topic, std::span<const std::byte> payload);  // false: the run stops
  // Output to a service (flow control: FlowControl, service_runtime.hpp, keeps the order, the pool, the count).
  void push_ring(ServiceRuntime& s, broker::SubscriberId subscriber);
  // What the polled subscriptions of `s` have pending, pushed ahead of a frame that wakes `s` anyway.
  void hand_over_polled(ServiceRuntime& s);
  void send_control(ServiceRuntime& s, std::span<const std::byte> frame);
  void drain(ServiceRuntime& s);
  void cork();    // opens the output batch (output_batch.hpp) for a routing round
  void uncork();  // closes it and flushes every service's frames
  void uncork_service(ServiceRuntime& s);
  enum class SendResult : std::uint8_t { Sent, Blocked, Failed };
  SendResult send_now(ServiceRuntime& s, std::span<const std::byte> frame);
  bool deliver_one(ServiceRuntime& s, broker::SubscriberId subscriber);  // false: nothing pending or blocked
  void set_writable_interest(ServiceRuntime& s, bool want);

  // ---- network gate (netgate.cpp) ----
  // Opens the UDP socket of the launch graph's `network` (at create; realtime: registered in epoll).
  [[nodiscard]] Result<void, KernelError> net_open();
  // Reads up to kDatagramsPerPoll queued datagrams and relays or drops each (realtime: on wakeup;
  // lockstep: at the start of each step, so that what a service sees does not depend on scheduling).
  void net_poll();
  // NetSend / NetReceive invocations, decoded and their authority checked (handle_invoke): sends a datagram,
  // or records the receiver's verdict on a relayed one (NetDatagram aux).
  void net_invoke(ServiceRuntime& s, std::uint32_t seq, const cap::Invocation& authority, const NetInvocation& what);

  // ---- loop (loop.cpp) ----
  [[nodiscard]] Result<void, KernelError> pump(std::optional<Nanos> max_wait);
  void on_dds_ready(std::size_t reader);
  void sync_realtime_clock(std::span<const std::byte> first_sample);
  void fire_timers();
  void arm_timerfd();
  [[nodiscard]] bool all_idle() const;
  [[nodiscard]] bool all_ready() const;
  [[nodiscard]] std::optional<Nanos> next_wall_deadline() const;
  [[nodiscard]] Result<void, KernelError> run_realtime();  // Kernel::run with the realtime clock

  // ---- lockstep (lockstep.cpp) ----
  void take_steps();       // the SimSteps that arrived, through the bridge's lockstep adapter
  void collect_samples();  // takes every sample reader (lockstep with the plant: on each SimStep)
  void stage_sample(std::size_t reader, std::span<const std::byte> bytes);
  void watch_sample_readers(bool watch);  // lockstep: also wake on samples while a step waits for them
  void begin_step(const PendingStep& step);
  // Advances the active lockstep step by one round when every service is idle; true when it is complete.
  bool advance_step();
  void finish_step();
  [[nodiscard]] Nanos pace_wait();  // how long the next lockstep step must wait for options.speed (0: none)
  std::optional<std::pair<Nanos, Nanos>> pace_origin{};  // (kernel clock, wall) at the first paced step
  void check_stop_conditions();
  [[nodiscard]] Result<void, KernelError> run_lockstep();  // Kernel::run in lockstep with the plant
};

// vocabulary.cpp: a KernelError without findings; whether a stop waits for the step in progress to be
// acknowledged (the others end the loop at once).
[[nodiscard]] KernelError kernel_error(KernelError::Kind kind, std::string message);
[[nodiscard]] bool graceful(StopReason reason);

// ReplyHeader::error of an operation error (docs/protocol.md: ≥ 100): the wire's one definition.
using channel::op_code;

// The boot params of a service: its own launch params, then the graph-wide ones (services/sdk service.hpp).
[[nodiscard]] std::vector<wire::BootParam> build_params(const Kernel::Impl& k, const ServiceRuntime& s);

}  // namespace rejuv::kernel
