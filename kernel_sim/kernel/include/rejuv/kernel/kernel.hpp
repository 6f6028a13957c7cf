// The kernel process (docs/design.md §2, §5, §6; docs/protocol.md): the trusted parent of every service. From
// a launch graph it loads and audits the policy (refusing to start on any finding), builds the capability
// system and the broker, opens the DDS bridge, spawns every service as an isolated child with its channel
// (fd 3) and the read-only time page (fd 4), runs the boot protocol and then one event loop that routes
// every publication through the capability check and the broker, fires kernel timers against the kernel
// clock (lockstep with the plant as time master, or realtime), supervises every child through its pidfd and
// shuts everything down cleanly (SIGINT/SIGTERM, mission end, a duration limit, or a failure).
//
// With SR (docs/design.md §7) the image store checkpoints every rejuvenated service by written pages or fork,
// with the broker's queue state, and rolls them back on the rejuvenation timer, on a lost service or on a
// sandbox violation in MC (rejuvenator.cpp); a lost driver-level service, or any loss without SR, ends the
// run (supervisor.cpp). Containment: warden.cpp and docs/sandbox.md.
//
// Single-threaded: the kernel's event loop owns everything; Cyclone's threads only signal eventfds.
//
// The implementation (kernel_sim/kernel/src): Kernel::Impl (impl.hpp) holds the configuration, the shared
// components and the services (a service's record, by concern, in service_runtime.hpp), and composes the
// owners, each a class with its state and its procedures: Supervisor (supervisor.hpp: supervisor.cpp
// processes, realtime.cpp the real-time plan), ChannelInput (channel_input.hpp: channel_input.cpp channel
// requests, invoked per object kind, invocation.hpp), Router (router.hpp: router.cpp routing and flow
// control, watch.cpp the observers of the routed traffic), Lockstep (lockstep.hpp: lockstep.cpp the steps and
// the samples that ride on them), Rejuvenator (rejuvenator.hpp: the image coordinator; images.hpp what its
// files share, rejuvenator.cpp with its overview, checkpoint.cpp, rollback.cpp, checkpointed_state.cpp;
// catch_up.hpp/.cpp the estimate catch-up after a rollback; link_guard.hpp/.cpp the links to other hosts
// closed in the secure interval) and Warden (warden.hpp: warden.cpp containment, built alone from WardenParts
// and WardenPeers; cgroup_placer.hpp/.cpp the moves between a service's cgroup leaves, on a thread of its
// own). owner_peers.cpp: what an owner built alone asks of the others, answered from Kernel::Impl. Impl's
// own: kernel.cpp this API; create.cpp Kernel::create in named steps; loop.cpp the event loop, timers,
// deadlines and the realtime clock; netgate.cpp the network gate; vocabulary.cpp the enums' names and
// KernelError; bridge.hpp/.cpp the DDS bridge with the plant's lockstep adapter (kernel_sim/dds);
// scripted.cpp the fuzzer's seam. Smaller parts that own their state, unit-tested: kernel_clock.hpp (the time
// page's one writer), step_clock.hpp (the lockstep step queue and its deadlines), image_coordinator.hpp (the
// checkpoint and rollback requests, the work left, the rejuvenation timer), vehicle_pace.hpp (when in the
// control period image work disturbs the vehicle least), liveness_watch.hpp (who is hung in real time),
// cpu_wait.hpp/.cpp (a late answer judged by the CPU its processes had), reaper.hpp (retired and dying
// processes), channel_pool.hpp (socket pairs made ahead), routing_freeze.hpp (routing held while image work
// is timed), image_charge.hpp (its simulated-time charge), canonical_stage.hpp (lockstep staging),
// fixed_ring.hpp (a bounded FIFO allocated once), output_batch.hpp, netgate.hpp, mission_watch.hpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/broker/broker.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/cap/cap_system.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/sr_event.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/dds/run_partition.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/mavlink/frame.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::kernel {

// Who keeps time (docs/design.md §6).
enum class ClockMode : std::uint8_t {
  Lockstep,  // simulated time, advanced by the time master one step at a time; deterministic for a seed
  Realtime,  // CLOCK_MONOTONIC since the start of the run; timers through a timerfd
};
[[nodiscard]] std::string_view to_string(ClockMode mode);

// Where lockstep steps come from.
enum class TimeMaster : std::uint8_t {
  Plant,   // the plant process publishes SimStep over DDS and waits for SimStepAck (PX4 lockstep)
  Manual,  // the caller drives Kernel::step() (tests and tools without a plant)
};

// Why a run ended.
enum class StopReason : std::uint8_t {
  MissionDone,     // a Setpoint with mission_done = 1 was published
  MissionTimeout,  // kernel time reached the mission's timeout_s
  Duration,        // kernel time reached KernelOptions::duration
  Signal,          // SIGINT or SIGTERM
  ServiceFailed,   // a service died or hung and could not be recovered (SR off: always)
  PlantExited,     // the plant process exited by itself
  PlantProtocol,   // a SimStep that does not follow the last (another plant on the DDS domain): refused
  Requested,       // request_stop()
};
[[nodiscard]] std::string_view to_string(StopReason reason);
// Whether the mission counts as failed for this reason (`rejuv run` exits 1).
[[nodiscard]] bool is_failure(StopReason reason);

struct KernelOptions {
  std::optional<ClockMode> clock{};             // default: the graph's `clock`
  TimeMaster time_master = TimeMaster::Plant;   // Plant: the graph's plant is spawned (lockstep and realtime)
  std::optional<std::uint64_t> seed{};          // default: the graph's seed
  std::optional<std::uint32_t> dds_domain{};    // default: the graph's dds.domain_id
  // The run's DDS partition (rejuv/dds/run_partition.hpp): its bridge and its plant use `rejuv.<run_id>`, so
  // that two runs on one domain never hear each other. Default: 64 fresh random bits (dds::random_run_id).
  std::optional<dds::RunId> run_id{};
  // Rejuvenation (docs/design.md §7–8): the graph's `sr.enabled` unless disabled here.
  bool no_sr = false;
  bool no_attack = false;                       // attack.enabled = 0 for every service
  std::optional<Nanos> duration{};              // stop when the kernel clock reaches this
  bool stop_on_mission_done = true;             // false: run to `duration` (e.g. hover) even after mission end
  std::filesystem::path service_dir{};          // where service and plant executables are
  std::filesystem::path repo_root{};            // for the default DDS config (config/cyclonedds.xml)
  std::vector<std::string> skip_services{};     // graph services not to start (e.g. not built yet)
  std::vector<std::string> plant_args{};        // extra arguments for the plant process
  // Real-time bounds so that a hung service cannot hang the kernel (faults, not timings).
  Nanos boot_deadline{std::chrono::seconds{20}};      // spawn → Ready
  // A lockstep step: every service idle. A service late at it that is runnable and has had less than this
  // much CPU since is waiting for the machine, not hung (cpu_wait.hpp): waited for up to ten deadlines from
  // the step's start, and never past 50 s. Below the plant's ack timeout (60 s), so that a hung service is
  // found (and, with SR, rolled back) before the plant gives up.
  Nanos idle_deadline{std::chrono::seconds{5}};
  Nanos shutdown_grace{std::chrono::seconds{2}};      // Shutdown → exit, before SIGKILL
  // Snapshot → Taken from every service (docs/design.md §7 Faults), where the vehicle waits with the checkpoint
  // (real time, measured charge): routing is frozen meanwhile, so the controls the vehicle flies are as old as
  // the wait. An image takes well under a millisecond; a service that stopped (SIGSTOP) at a Snapshot and was
  // waited for 2 s lost the vehicle (max V 481) in the real-time fault campaign under load. Past it the
  // checkpoint is abandoned and the late service killed, which rolls back (rollback.cpp).
  Nanos snapshot_deadline{std::chrono::milliseconds{100}};
  // The same bound where the wait does not reach the vehicle (lockstep with the model's charge), wide so that
  // a slow machine does not change the run (as unseen_resume_deadline).
  Nanos unseen_snapshot_deadline{std::chrono::seconds{2}};
  // Real time: a rejuvenated service that went silent with frames it has not reported is sent a Sync; one that has
  // not answered with its Idle within this is hung and killed (Supervisor::watch_liveness), which rolls back.
  // A control service answers within a control period; this leaves a wide margin for one that the real-time
  // plan could not give SCHED_FIFO and that shares a loaded CPU.
  Nanos realtime_hang_deadline{std::chrono::milliseconds{200}};
  // The same for a service the real-time plan runs at SCHED_FIFO: above every process but the kernel and the
  // plant, it answers within a control period or two. At 200 ms (and up to 100 ms of silence before the Sync) a
  // safety controller stopped in the secure interval leaves the vehicle on its last command for a third of a
  // second, enough to leave the safety set under a 2-CPU load (docs/realtime.md "Faults in real time").
  Nanos realtime_chain_hang_deadline{std::chrono::milliseconds{30}};
  // Resume → Resumed from every image. The rollback waits for it without routing, and in lockstep its real
  // duration is charged to simulated time with the controls held (docs/design.md §6): a frozen image (SIGSTOP) that
  // cost 2 s here lost the vehicle in 13 of 13 fallbacks of the fault campaign. A resume takes well under a
  // millisecond (docs/performance.md), so 100 ms leaves a wide margin and falls back in time.
  Nanos resume_deadline{std::chrono::milliseconds{100}};
  // The same bound where the rollback's real duration does not reach the vehicle: lockstep with the model's
  // charge (the default; manual stepping too). There a slow machine must not change the run: on 2 loaded
  // cores a fresh image's copy (fork, apply the written pages, touch its working set) missed 100 ms and
  // fell back, twice in a row, in 3 of 15 runs of Images.ThousandCycles; a lockstep run with one seed would
  // then not repeat. Still bounded: a frozen image costs this much wall time, never simulated time, and the
  // bound is the whole rollback's (a fallback gets at least resume_deadline), below the plant's ack timeout.
  Nanos unseen_resume_deadline{std::chrono::seconds{2}};
  // Images by written pages (docs/design.md §7, docs/protocol.md "Checkpoint and rollback"): a Snapshot offers the
  // base generation a service's memory derives from, so that it need not fork. false: every image by fork
  // (tests compare the two ways).
  bool images_by_pages = true;
  // Lockstep charges (docs/design.md §6): Model charges the simulated time the launch file gives a checkpoint and a
  // rollback (lockstep.*_charge_ms), so that two runs with one seed are identical; Measured charges their real
  // durations (timing studies: the gaps of Fig. 7 as this machine makes them). Both are reported (SrStats).
  enum class Charge : std::uint8_t { Model, Measured };
  Charge charge = Charge::Model;
  // Lockstep paced to this many times real time (`rejuv run --speed`, as PX4 SITL's PX4_SIM_SPEED_FACTOR), so
  // that a ground station living in wall-clock time can follow a simulated flight: a step begins no earlier
  // than its simulated time divided by the speed after the run's first step. Unset: as fast as it can. Pacing
  // waits only, so the run stays deterministic for a seed.
  std::optional<double> speed{};
  // Network gate (docs/design.md §2): the UDP port of the external link, overriding the graph's `network.bind_port`
  // (0 = ephemeral: Kernel::network_port() tells which; tests use it).
  std::optional<std::uint16_t> network_port{};
  // CPU placement (docs/design.md §6). A lockstep step is one chain of wake-ups (plant → kernel → services → kernel →
  // plant) with nothing to run in parallel: on one CPU each hop is a context switch; across CPUs it is an
  // inter-processor interrupt that, on a virtual machine whose idle vCPU halts, costs tens of µs (the square
  // without SR: 3.1× real time spread over 2 vCPUs, 9.7× on one; docs/performance.md). Auto pins a lockstep
  // run to the CPU the kernel is on and leaves a realtime run alone; Cpu pins to `cpu`; Spread never pins.
  enum class Placement : std::uint8_t { Auto, Cpu, Spread };
  Placement placement = Placement::Auto;
  int cpu = 0;                                  // with Placement::Cpu
  // Containment (docs/design.md §7 "Protection"): Strict runs every service in an empty network namespace and a
  // read-only mount namespace, and refuses to start where they cannot be made; Insecure (rejuv run
  // --insecure-sandbox) runs without them and says so in the summary. The allow-list filter, the resource
  // limits, the sweeps and the logged output hold in both.
  enum class Sandbox : std::uint8_t { Strict, Insecure };
  Sandbox sandbox = Sandbox::Strict;
  std::FILE* log = stderr;                      // kernel and service log lines; nullptr = silent
  bool verbose = false;                         // also Debug-level service logs
};

// A failure to create, boot or run the kernel.
struct KernelError {
  enum class Kind : std::uint8_t {
    Policy,          // the policy file cannot be loaded (message has file:line:col)
    Audit,           // the policy fails the audit: `findings` lists them
    Config,          // the graph or the options cannot run (unknown topic type, missing executable, ...)
    Dds,             // the DDS bridge failed
    System,          // a system call failed
    Boot,            // a service failed to boot (exec failure, protocol, deadline)
  };
  Kind kind = Kind::Config;
  std::string message{};
  std::vector<std::string> findings{};
  [[nodiscard]] std::string to_string() const;
  // Input the loaders or the kernel refused (Policy, Config): `rejuv run` exits 2 on those; an Audit finding
  // exits 1, as in `rejuv audit` (README "Exit codes").
  [[nodiscard]] bool is_bad_input() const;
};

// An accepted publication, as the kernel routed it (for recorders: `rejuv run` computes its metrics here).
struct Publication {
  ObjectId topic{};
  std::string_view name{};      // policy object name, e.g. "ground_truth"
  std::string_view type{};      // IDL type name
  std::span<const std::byte> payload{};
  broker::TopicGeneration generation{};
  Nanos t{0};                   // kernel clock when routed
  std::optional<ServiceId> publisher{};  // nullopt: the kernel itself or the DDS bridge
};

// The phase boundaries inside a checkpoint and a rollback (docs/design.md §7), for fault injection (`rejuv faults`,
// docs/design.md §11): a fault placed exactly there tests the paths that a fault at a step boundary cannot reach.
enum class ImagePhase : std::uint8_t {
  CheckpointSnapshotsSent,  // routing frozen, every Snapshot sent, no Taken read yet
  CheckpointTaken,          // every Taken read, the generation not yet saved nor committed
  RollbackKilled,           // mode RB, the live rejuvenated services cut off, no Resume sent yet
  RollbackResumesSent,      // every Resume of the generation tried sent, no Resumed read yet
};
inline constexpr std::array kAllImagePhases{ImagePhase::CheckpointSnapshotsSent, ImagePhase::CheckpointTaken,
                                            ImagePhase::RollbackKilled, ImagePhase::RollbackResumesSent};
[[nodiscard]] std::string_view to_string(ImagePhase phase);

// A log line of the kernel (`source` "kernel") or of a service (its name), as printed to KernelOptions::log
// (after the services' rate limit; Debug lines only with `verbose`), also when that is nullptr.
struct LogLine {
  enum class Level : std::uint8_t { Debug, Info, Warning, Error };
  Nanos t{0};                   // kernel clock
  std::string_view source{};
  Level level = Level::Info;
  std::string_view text{};
};


// Receives what happens during a run. Called from the kernel's loop: must not block. Every hook is a
// virtual call behind one null check, so a run without an observer pays a branch per event.
class Observer {
 public:
  Observer() = default;
  Observer(const Observer&) = delete;
  Observer& operator=(const Observer&) = delete;
  virtual ~Observer() = default;
  virtual void on_publication(const Publication& /*publication*/) {}
  // After every completed lockstep step (or, in realtime, about every 100 ms of kernel time).
  virtual void on_step(std::uint64_t /*step*/, Nanos /*t*/, SrMode /*mode*/) {}
  // docs/design.md §7: generation g has just been saved / the queues have just been restored to g (nothing has
  // run since). Tests compare the broker's state at both points.
  virtual void on_checkpoint(Generation /*g*/, const broker::Broker& /*queues*/) {}
  virtual void on_restore(Generation /*g*/, const broker::Broker& /*queues*/) {}
  // The fault-injection seam: called at each ImagePhase boundary of a checkpoint or rollback of generation
  // `g` (a rollback: the generation it tries; again for each one it falls back to). Only for observers; the
  // kernel does nothing else there.
  virtual void on_image_phase(ImagePhase /*phase*/, Generation /*g*/) {}
  // Fig. 7 (§VI-B): every control update, i.e. every ActuatorOutputs the kernel routes (the output driver's,
  // on their way to the plant), at kernel time `t` and real (monotonic) time `wall`. On the hot path: an
  // observer keeps what it needs without allocating per call.
  virtual void on_control_update(Nanos /*t*/, Nanos /*wall*/) {}
  // Fig. 8: what the SR machinery did (mode transitions, timer arms and refusals, limits, checkpoints,
  // rollbacks, cold restarts), as the kernel saw it: no service log needed.
  virtual void on_sr_event(const SrEvent& /*event*/) {}
  // Every log line of the kernel and of the services it relays (ULog, docs/ulog.md).
  virtual void on_log(const LogLine& /*line*/) {}
};

// Hands every event to each of several observers in turn (e.g. `rejuv run`'s metrics and its ULog). One
// may be added after Kernel::create (it may need the kernel), before the kernel boots.
class ObserverFanout final : public Observer {
 public:
  ObserverFanout() = default;
  explicit ObserverFanout(std::vector<Observer*> observers) : observers_(std::move(observers)) {}
  void add(Observer* observer) { observers_.push_back(observer); }
  void on_publication(const Publication& p) override { for (Observer* o : observers_) o->on_publication(p); }
  void on_step(std::uint64_t step, Nanos t, SrMode mode) override {
    for (Observer* o : observers_) o->on_step(step, t, mode);
  }
  void on_checkpoint(Generation g, const broker::Broker& q) override { for (Observer* o : observers_) o->on_checkpoint(g, q); }
  void on_restore(Generation g, const broker::Broker& q) override { for (Observer* o : observers_) o->on_restore(g, q); }
  void on_image_phase(ImagePhase phase, Generation g) override { for (Observer* o : observers_) o->on_image_phase(phase, g); }
  void on_log(const LogLine& line) override { for (Observer* o : observers_) o->on_log(line); }
  void on_sr_event(const SrEvent& e) override { for (Observer* o : observers_) o->on_sr_event(e); }
  void on_control_update(Nanos t, Nanos wall) override { for (Observer* o : observers_) o->on_control_update(t, wall); }

 private:
  std::vector<Observer*> observers_;
};

// Per-service counters, for tests, the summary and diagnostics.
struct ServiceStats {
  std::string name{};
  bool started = false;             // false when skipped
  bool alive = false;
  bool ready = false;
  int pid = -1;
  std::optional<sys::ExitStatus> exit{};
  bool hung = false;                // missed a deadline and was killed
  std::uint64_t frames_in = 0;      // frames received from it
  std::uint64_t frames_out = 0;     // frames sent to it
  std::uint64_t bad_frames = 0;     // refused at framing or protocol level
  std::uint64_t publishes = 0;      // accepted publications
  std::vector<std::pair<std::string, std::uint64_t>> publishes_by_topic{};  // the same by topic (those it published on)
  // Its part in SR (docs/design.md §7): started from its binary (at boot and at each cold restart), images of it in
  // committed generations (the checkpoints it was part of) and incarnations resumed from one of them (rollbacks).
  std::uint64_t spawns = 0;
  std::uint64_t images = 0;
  std::uint64_t restores = 0;
  std::uint64_t denials = 0;        // refused by the capability check
  std::uint64_t wrong_size = 0;     // publications of the wrong size for the topic
  std::uint64_t delivered = 0;      // Deliver frames sent
  std::uint64_t lost = 0;           // messages its push subscriptions skipped (ring overrun; a polled one
                                    // skips what its service slept through by design and is not counted)
  std::uint64_t log_suppressed = 0; // log lines dropped by the rate limit
  std::uint64_t flood_dropped = 0;  // publications dropped over the per-step bound (lockstep)
  std::uint64_t publications_over_budget = 0;  // dropped over its publication budget (max_publications_per_s)
  // Containment (docs/design.md §7 "Protection", docs/sandbox.md): every violation is proof of compromise.
  std::uint64_t sandbox_violations = 0;  // all kinds below
  std::uint64_t forbidden_calls = 0;     // a call outside the allow-list (or a boot call after boot): killed
  std::uint64_t stray_processes = 0;     // a process of its session that is neither live nor an image: killed
  std::uint64_t out_of_memory = 0;       // OOM kills in its live cgroup leaf (its live incarnation or strays)
  std::uint64_t images_lost = 0;         // an image that died, stopped or did not answer in the store (a rollback
                                         // found its generation unusable and fell back)
  std::vector<std::pair<std::string, std::uint64_t>> calls_refused{};  // forbidden calls by name
  std::uint64_t output_lines = 0;        // lines it wrote on fds 1-2 (logged under its name)
  std::string cgroup{};                  // what its cgroup bounds ("cgroup v2 (cgroup.kill), pids.max 64 …"), or why none
};

// NetReceive verdict codes: 0 = valid, 1 … kNetVerdictCodes − 1 = the receiver's refusal reasons (the wire's).
inline constexpr std::size_t kNetVerdictCodes = wire::kNetVerdictCodes;

// Counters of the network gate (docs/design.md §2; docs/protocol.md "Network gate"). Every datagram read is
// received = relayed + the dropped_* counters.
struct NetStats {
  std::uint64_t received = 0;                 // datagrams read from the kernel's UDP socket
  std::uint64_t relayed = 0;                  // handed to the service holding Network Read (NetDatagram)
  std::uint64_t dropped_secure_interval = 0;  // no service holds Network Read in the current mode (SEI)
  std::uint64_t dropped_oversize = 0;         // longer than wire::kMaxDatagramBytes
  std::uint64_t dropped_empty = 0;            // zero bytes
  std::uint64_t dropped_no_receiver = 0;      // the holder is not running (skipped, dead, still booting)
  std::uint64_t dropped_busy = 0;             // the holder's channel is backed up (it is not reading)
  std::uint64_t sent = 0;                     // NetSend datagrams sent to the ground station
  std::uint64_t send_refused = 0;             // NetSend refused: denied by the cap check, bad data, send error
  std::uint64_t unsent_no_ground = 0;         // NetSend before any ground station spoke (Refused, not counted above)
  // The receiver's verdicts on relayed datagrams (NetReceive, docs/protocol.md "Network gate"): valid ones
  // make their source the ground station; refused ones are counted by the receiver's reason code 1 … 31
  // (ext_link: 1 + link::DecodeError). Kernel state, so a rollback does not erase them.
  std::uint64_t judged_valid = 0;
  std::uint64_t judged_refused = 0;
  std::array<std::uint64_t, kNetVerdictCodes> refused_by_reason{};  // index = code; [0] unused
  // MAVLink 2 signing, checked by the gate before anything is relayed (launch network.signing_key): the
  // datagrams refused, by mavlink::SigningRefusal. They reach no service and name no ground station.
  bool signing = false;
  std::uint64_t signing_refused = 0;
  std::array<std::uint64_t, mavlink::kSigningRefusalCount> signing_refused_by_reason{};
};

// Durations of one kind [ms], bounded: the first kCapacity are kept, after that each new one replaces a
// uniformly chosen kept one with probability kCapacity / count (reservoir sampling, Vitter's algorithm R, with
// a fixed-seed generator so that a lockstep run stays deterministic). A kernel that runs for days then holds
// at most 8 kB per series instead of 8 bytes per SR cycle for ever (what `rejuv soak` checks); the count and
// the maximum stay exact, the median is that of a uniform sample (exact up to kCapacity durations).
class DurationSamples {
 public:
  static constexpr std::size_t kCapacity = 1024;
  void add(double ms) {
    ++count_;
    if (count_ == 1 || ms > max_) max_ = ms;
    if (kept_.size() < kCapacity) {
      if (kept_.capacity() < kCapacity) kept_.reserve(kCapacity);  // one allocation, not a doubling each time
      kept_.push_back(ms);
      return;
    }
    // splitmix64: a uniform index in [0, count_); kept when it falls inside the reservoir.
    state_ += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    if (const std::uint64_t j = z % count_; j < kCapacity) kept_[j] = ms;
  }
  [[nodiscard]] std::span<const double> values() const { return kept_; }  // the sample, in no order
  [[nodiscard]] std::uint64_t count() const { return count_; }           // every duration added
  [[nodiscard]] double max() const { return max_; }                       // 0 when none
  [[nodiscard]] bool empty() const { return count_ == 0; }
  // The q-quantile (0 ≤ q ≤ 1, nearest rank) of the sample; 0 when empty.
  [[nodiscard]] double quantile(double q) const {
    if (kept_.empty()) return 0;
    std::vector<double> sorted = kept_;
    const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
    const std::size_t i = std::min(sorted.size() - 1, rank > 0 ? rank - 1 : 0);
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(i), sorted.end());
    return sorted[i];
  }

 private:
  std::vector<double> kept_{};
  std::uint64_t count_ = 0;
  double max_ = 0;
  std::uint64_t state_ = 0;
};

// What the image store did (docs/design.md §7): counts, and the real duration of every checkpoint and rollback
// (the Fig. 7 analogue; in lockstep also charged to simulated time).
struct SrStats {
  std::uint64_t checkpoints = 0;          // generations committed
  std::uint64_t checkpoint_failures = 0;  // generations abandoned (a refusal, a deadline, a dead image)
  std::uint64_t rollbacks = 0;            // rollbacks carried out (to some generation)
  std::uint64_t fallbacks = 0;            // generations skipped as broken during a rollback
  std::uint64_t passed_over = 0;          // real time: generations skipped as busy to resume (no loss)
  std::uint64_t cold_restarts = 0;        // no usable generation: the graph restarted from its binaries
  std::uint64_t timer_arms = 0;           // rejuvenation timer arms accepted
  std::uint64_t timer_arm_refused = 0;    // a second arm in one epoch (docs/design.md §7)
  std::uint64_t timer_rollbacks = 0;      // rollbacks the rejuvenation timer fired
  std::uint64_t images_by_fork = 0;       // service images taken by fork (Taken)
  std::uint64_t images_by_pages = 0;      // service images taken by written pages (TakenPages)
  // Charges (docs/design.md §6): the simulated time charged for checkpoints and rollbacks (lockstep with a plant;
  // KernelOptions::charge) and their real durations, in all.
  Nanos charged{0};
  Nanos measured{0};
  std::optional<double> first_checkpoint_ms{};  // the real duration of the first checkpoint of the flight [ms]
  // The untimed checkpoint of the alignment (docs/design.md §6: SR starts with the flight) that makes every service's
  // first image by fork, so that no checkpoint in flight pays for one; counted here only.
  std::uint64_t priming_images = 0;
  DurationSamples checkpoint_ms{};        // Snapshot sent → generation committed, per checkpoint
  DurationSamples rollback_ms{};          // trigger → routing resumed, per rollback
  // Phases (docs/design.md §7 "durations of every phase"): checkpoint = freeze + Snapshots sent, Taken awaited,
  // state saved + committed; rollback = mode RB + services killed, images resumed, state restored.
  struct Phases {
    DurationSamples a{}, b{}, c{};
  };
  Phases checkpoint_phases{};  // a: snapshot, b: taken, c: save  [ms]
  Phases rollback_phases{};    // a: kill, b: resume, c: restore  [ms]
  DurationSamples catch_up_ms{};  // the estimate catch-up after a rollback, per replay (launch sr.estimate_catch_up)
};

// The estimate catch-up after a rollback (launch sr.estimate_catch_up; docs/control.md §6.3): the plant's samples
// since the restored generation's cut, replayed through the restored estimator chain.
struct CatchUpStats {
  std::uint64_t replays = 0;      // rollbacks followed by a replay
  std::uint64_t samples = 0;      // samples replayed, in all
  std::uint64_t dropped = 0;      // publications of the chain held from the services outside it meanwhile
  std::uint64_t without_log = 0;  // rollbacks to a generation whose samples were no longer all kept
  std::uint64_t cut_short = 0;    // replays ended at the kernel's bound, the chain not done: the estimator re-armed
  std::uint64_t discarded = 0;    // replayed estimates the estimator found implausible against the live samples
                                  // and discarded for a re-arm (docs/control.md §6.3)
};

// Result of one manual lockstep step.
struct StepReport {
  std::uint64_t step = 0;
  Nanos t{0};
  std::uint32_t rounds = 0;         // routing rounds until every service was idle
  std::vector<ServiceId> hung{};    // services that missed the idle deadline in this step (now killed)
};

// What a run did.
struct RunOutcome {
  StopReason reason = StopReason::Requested;
  std::string detail{};
  std::uint64_t steps = 0;
  Nanos sim_time{0};
  Nanos wall_time{0};
};

class Kernel {
 public:
  // Loads and audits the policy (with the graph), compiles it, creates the capability system, the broker,
  // the time page and (TimeMaster::Plant or bridges present) the DDS bridge. Spawns nothing yet.
  [[nodiscard]] static Result<std::unique_ptr<Kernel>, KernelError> create(launch::LoadedLaunch graph,
                                                                           KernelOptions options,
                                                                           Observer* observer = nullptr);
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;
  Kernel(Kernel&&) = delete;
  Kernel& operator=(Kernel&&) = delete;
  // Shuts down if still running: every child killed and reaped, every fd closed.
  ~Kernel();

  // Spawns the services (and, with TimeMaster::Plant, the plant) and runs the boot protocol until every
  // service is Ready. On failure everything started is stopped again.
  [[nodiscard]] Result<void, KernelError> boot();
  // Lockstep, TimeMaster::Manual: advance the kernel clock to `t`, fire due timers, route until every
  // service is idle. Returns after the step (a service that misses the idle deadline is killed and the
  // stop reason set).
  [[nodiscard]] Result<StepReport, KernelError> step(Nanos t);
  // Boots if needed, runs until a stop condition, shuts down. TimeMaster::Plant, or realtime.
  [[nodiscard]] Result<RunOutcome, KernelError> run();
  // Shutdown to every service, the grace period, then SIGKILL and reap; the plant gets SIGTERM first.
  // Idempotent.
  void shutdown();
  void request_stop();

  // The kernel's own checkpoint / rollback (benchmarks, tools; TimeMaster::Manual between steps): the same
  // protocol as a service's CheckpointCreate / CheckpointRollback. `cold`: the restart-based baseline (every
  // rejuvenated service killed and started again from its binary, docs/design.md §7 Faults).
  [[nodiscard]] Result<Generation, KernelError> checkpoint_now();
  [[nodiscard]] Result<void, KernelError> rollback_now(bool cold = false);

  // Publishes `payload` on topic `name` as the kernel (the DDS bridge path; tests use it in Manual mode).
  [[nodiscard]] Result<void, KernelError> inject(std::string_view topic, std::span<const std::byte> payload);

  // ---- inspection ----
  [[nodiscard]] std::optional<StopReason> stop_reason() const;
  [[nodiscard]] const std::string& stop_detail() const;
  [[nodiscard]] Nanos now() const;
  [[nodiscard]] SrMode mode() const;
  [[nodiscard]] ClockMode clock_mode() const;
  // The run id whose partition the bridge and the plant are in (KernelOptions::run_id).
  [[nodiscard]] dds::RunId run_id() const;
  [[nodiscard]] bool sr_enabled() const;
  // Whether the image work of the last checkpoint or rollback (patches, spares, the sweep) still waits for
  // the vehicle's next control update (rejuvenator.cpp leave_image_work): what a sample of processes and fds
  // would see.
  [[nodiscard]] bool image_work_pending() const;
  [[nodiscard]] const cap::CapSystem& caps() const;
  [[nodiscard]] const broker::Broker& broker() const;
  [[nodiscard]] std::size_t service_count() const;
  [[nodiscard]] std::optional<ServiceId> find_service(std::string_view name) const;
  [[nodiscard]] ServiceStats stats(ServiceId service) const;
  [[nodiscard]] std::uint64_t bad_frames_total() const;
  [[nodiscard]] const SrStats& sr_stats() const;
  [[nodiscard]] const CatchUpStats& catch_up_stats() const;
  [[nodiscard]] Epoch epoch() const;
  // The kernel time of the mission's t = 0: the end of the plant's pre-flight alignment (launch lockstep.
  // alignment_s). SR starts there (docs/design.md §6).
  [[nodiscard]] Nanos flight_start() const;
  // pids of the frozen images of a service, oldest generation first (tests and fault injection).
  // Reads the spare copies' reports first, so that every frozen copy is listed.
  [[nodiscard]] std::vector<int> image_pids(ServiceId service);
  [[nodiscard]] std::vector<int> image_pids(ServiceId service, Generation g);
  [[nodiscard]] std::vector<Generation> generations() const;
  // The plant process's pid (nullopt: not started or already reaped): fault injection.
  [[nodiscard]] std::optional<int> plant_pid() const;
  // Waits (briefly) until the asynchronous image work is done: requested spares reported, retired
  // generations destroyed, killed incarnations reaped, cgroup moves done. Tests count processes and fds after it.
  void settle_images();
  // The network gate (netgate.cpp): its counters, and the UDP port it is bound to (nullopt: no gate).
  [[nodiscard]] NetStats net_stats() const;
  [[nodiscard]] std::optional<std::uint16_t> network_port() const;
  [[nodiscard]] const launch::LoadedLaunch& graph() const;
  // Every topic of the graph's policy, in object order (recorders define their formats from it).
  struct TopicInfo {
    ObjectId id{};
    std::string_view name{};   // policy object name
    std::string_view type{};   // IDL type name
    std::size_t size = 0;      // its payload [bytes]
  };
  [[nodiscard]] std::vector<TopicInfo> topics() const;

  // ---- test seam: the channel-input fuzzer only (tests/fuzz/channel_frames.cpp) ----
  // Instead of boot(): every service is attached to a socket pair with no process behind it, in phase
  // Spawned (as right after exec), and the graph counts as booted, so that step() runs. A scripted service
  // counts as idle in a lockstep step (no Idle frames needed). Returns the services' ends, by ServiceId
  // (empty for a skipped service); the caller reads them to keep the channels from filling up.
  [[nodiscard]] Result<std::vector<sys::SeqPacket>, KernelError> attach_scripted_services();
  // Handles `datagram` exactly as read_channel handles one read from the service's channel (framing,
  // protocol phase, request handlers, staging for the router), then drains the capability denials as the
  // loop does after each wake-up. Ignored for a service that is not live.
  void inject_datagram(ServiceId service, std::span<const std::byte> datagram);

  struct Impl;

 private:
  explicit Kernel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rejuv::kernel
