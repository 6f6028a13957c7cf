// The service SDK (docs/design.md §2, §5, §6; docs/protocol.md): what a service links to talk to the kernel.
//
// A service is an untrusted, isolated process. It reaches nothing except through its channel to the
// kernel (fd 3) and the kernel's read-only time page (fd 4). This library speaks the wire protocol of
// kernel_sim/channel/wire.hpp for it and gives the service author a small, typed, single-threaded API:
//
//   int main() {
//     return rejuv::sdk::run_service([](rejuv::sdk::Service& svc) {  // rejuv/sdk/run.hpp: Hello/Boot
//       const double gain = svc.param("gain", 1.0);
//       auto out = svc.advertise<rejuv_msg_ActuatorControls>("actuator_controls");
//       if (!svc.require(out, "actuator_controls")) return 1;
//       auto est = svc.subscribe<rejuv_msg_VehicleStateEstimate>("vehicle_state");
//       if (!svc.require(est, "vehicle_state")) return 1;
//       auto tick = svc.every(std::chrono::milliseconds(4), [&] {
//         if (!est->updated()) return;
//         const rejuv_msg_VehicleStateEstimate& x = est->copy();
//         rejuv_msg_ActuatorControls u{};
//         u.timestamp_ns = x.timestamp_ns;
//         u.thrust_N = gain * -x.v_N_m_s[2];
//         (void)out->publish(u);
//       });
//       if (!svc.require(tick, "timer")) return 1;
//       return svc.run();  // Ready, then the event loop until Shutdown; the exit code
//     });
//   }
//
// (tests/unit/kernel/sdk_example_test.cpp compiles this example and checks that it is the one written here.)
// Kernel objects other than topics have typed handles (mode_control, limits, persistent, rejuvenation); the raw
// surface that security tests and the attack library need is in rejuv/sdk/testing.hpp, not here.
//
// Every fallible call returns Result<T, Error> (docs/conventions.md "Errors are values"). Handles (Publisher,
// Subscription, Timer) are small views into the Service and are valid as long as the Service lives; the
// Service is pinned in memory (returned by unique_ptr, neither copyable nor movable).
//
// Threads: the Service is single-threaded. Callbacks run on the thread that called run(); they must not
// block (a lockstep step waits until every service is idle, docs/protocol.md "Idle").
// Allocation: advertise/subscribe/every/after allocate once; publish, delivery, timers and the event loop
// allocate nothing per message.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "rejuv/cap/capability.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/clock/timers.hpp"
#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::sdk {

// ---- Errors ----

// What went wrong in an SDK call. One enum for the SDK (docs/conventions.md); Error adds the detail.
enum class SdkError : std::uint8_t {
  NotAService,       // fd 3 is not a channel, fd 4 not a time page, or REJUV_SERVICE is unset
  ChannelIo,         // a send or receive on fd 3 failed (errno in Error::detail)
  ChannelClosed,     // the kernel closed the channel
  Protocol,          // the kernel sent something the protocol does not allow here (boot sequence, reply)
  VersionMismatch,   // the kernel speaks another protocol version
  NoSuchObject,      // the boot info has no cap with that object name (the policy never grants it)
  WrongObjectKind,   // the cap is not of the kind the call needs (e.g. subscribe on a Checkpoint cap)
  TypeMismatch,      // the topic's IDL type or size differs from the C++ type asked for
  NeverGranted,      // the policy grants the needed right in no mode (e.g. advertise without Write)
  NotHeldInMode,     // the right is not held in the current mode: nothing was sent (publish)
  AlreadySubscribed, // one Subscription per topic per service
  TooManyTimers,     // more than kMaxTimers live timers
  NoSuchTimer,       // cancel of a timer that is not armed
  BadArgument,       // a local argument error (oversize data, zero period, ...)
  Denied,            // the kernel refused the request: Error::cap_error says why
  OperationFailed,   // the kernel accepted the cap but the operation failed: Error::wire_error ≥ 100
  RolledBack,        // this process is a restored image: the call it was in never gets an answer (docs/design.md §7)
  Resources,         // the process could not get a thread (its max_processes, memory): errno text in detail
};
[[nodiscard]] std::string_view to_string(SdkError error);

struct Error {
  SdkError code = SdkError::Protocol;
  std::optional<cap::CapError> cap_error{};  // set for Denied
  std::int32_t wire_error = 0;               // ReplyHeader::error as the kernel sent it (0 when local)
  std::string detail{};                      // human-readable context (object name, errno text, ...)
  [[nodiscard]] std::string to_string() const;  // "denied: InsufficientRights (checkpoint, TimerArm)"
};

template <class T>
using SdkResult = Result<T, Error>;

// Prints `error` to stderr as "[<REJUV_SERVICE>] cannot connect: ..." and returns the exit code to use (2).
int report_connect_failure(const Error& error);

using wire::LogLevel;

class Service;
namespace testing {
class RawAccess;  // rejuv/sdk/testing.hpp: the raw surface for security tests and the attack library
}  // namespace testing

// ---- Capabilities ----

// One cap of the service's boot info (docs/design.md §3): every cap it may ever hold, with its rights per mode.
struct CapInfo {
  std::string object;          // policy object name, e.g. "actuator_controls"
  Slot slot;                   // fixed CSpace slot (CPtr)
  ObjectKind kind = ObjectKind::Topic;
  std::array<Rights, kModeCount> rights{};  // by index_of(mode); none = slot empty in that mode
  std::string type;            // Topic: IDL type name, e.g. "rejuv::msg::ActuatorControls"
  std::size_t payload_size = 0;  // Topic: exact message size [bytes]
  [[nodiscard]] Rights rights_in(SrMode mode) const { return rights[index_of(mode)]; }
  [[nodiscard]] bool ever(Right r) const;  // held with `r` in at least one mode
};

// The scalar result of an Invoke and how many bytes of reply data were copied out.
struct InvokeReply {
  std::uint64_t value = 0;
  std::size_t data_size = 0;
};

// What checkpoint() returned in this process (docs/design.md §7 "Return value, not a semaphore").
struct CheckpointOutcome {
  enum class Kind : std::uint8_t {
    Taken,     // the live process: the image of generation g exists and is frozen
    Restored,  // an image of g, resumed by a rollback into `epoch`
  };
  Kind kind = Kind::Taken;
  Generation generation{};
  Epoch epoch{};
};

namespace detail {

// A subscription's state inside the Service; Subscription<T> is a typed view of it.
class SubscriptionBase {
 public:
  SubscriptionBase(Slot slot, std::string object) : slot_(slot), object_(std::move(object)) {}
  SubscriptionBase(const SubscriptionBase&) = delete;
  SubscriptionBase& operator=(const SubscriptionBase&) = delete;
  virtual ~SubscriptionBase() = default;

  // One Deliver: the payload size has been checked against the topic by the caller.
  void deliver(std::uint64_t generation, std::span<const std::byte> payload);

  [[nodiscard]] Slot slot() const { return slot_; }
  [[nodiscard]] const std::string& object() const { return object_; }
  [[nodiscard]] std::uint64_t generation() const { return generation_; }
  [[nodiscard]] std::uint64_t lost() const { return lost_; }
  [[nodiscard]] std::uint64_t received() const { return received_; }
  [[nodiscard]] bool updated() const { return updated_; }
  void mark_read() { updated_ = false; }
  [[nodiscard]] virtual std::size_t size() const = 0;

 protected:
  virtual void store_and_notify(std::span<const std::byte> payload) = 0;

 private:
  Slot slot_;
  std::string object_;
  std::uint64_t generation_ = 0;  // generation of the latest message (0 = none yet)
  std::uint64_t lost_ = 0;        // messages skipped (generation gaps: the kernel clamped the cursor)
  std::uint64_t received_ = 0;
  bool updated_ = false;
};

template <class T>
class TypedSubscription final : public SubscriptionBase {
 public:
  TypedSubscription(Slot slot, std::string object, std::function<void(const T&)> on_message)
      : SubscriptionBase(slot, std::move(object)), on_message_(std::move(on_message)) {}
  [[nodiscard]] const T& latest() const { return latest_; }
  [[nodiscard]] std::size_t size() const override { return sizeof(T); }

 private:
  void store_and_notify(std::span<const std::byte> payload) override {
    std::memcpy(&latest_, payload.data(), sizeof(T));
    if (on_message_) {
      on_message_(latest_);
    }
  }
  T latest_{};
  std::function<void(const T&)> on_message_;
};

}  // namespace detail

// ---- Workers (docs/design.md §7 "Threads") ----

class WorkerSet;

// What a worker thread's body gets. A worker must not call the Service (the Service is single-threaded);
// it talks to the event loop through its own synchronised state.
class WorkerContext {
 public:
  // Call regularly, holding no lock: blocks while the service takes a checkpoint (workers are parked
  // before the fork, so the image holds no half-done worker step). Returns false when the worker must
  // return (the service is stopping).
  bool park_point();
  // 0 in the process that spawned the worker; +1 each time a restored image re-spawned it.
  [[nodiscard]] std::uint32_t incarnation() const { return incarnation_; }

 private:
  friend class WorkerSet;
  WorkerContext(WorkerSet* set, std::uint32_t incarnation) : set_(set), incarnation_(incarnation) {}
  WorkerSet* set_;
  std::uint32_t incarnation_;
};

// ---- Topic handles ----

// The right to publish one topic (the cap with Write in some mode), typed by its C struct.
template <class T>
class Publisher {
 public:
  // Sends `message` if this service holds Write on the topic in the current mode (time page); otherwise
  // returns NotHeldInMode and sends nothing, so an honest service never causes a denial. The kernel is
  // still the authority: a mode change in flight can make it refuse (counted as a denial).
  SdkResult<void> publish(const T& message) const;
  // True when the current mode grants Write on this topic.
  [[nodiscard]] bool allowed() const;
  [[nodiscard]] Slot slot() const { return slot_; }

 private:
  friend class Service;
  friend class testing::RawAccess;
  Publisher(Service* service, const CapInfo* cap) : service_(service), cap_(cap), slot_(cap->slot) {}
  Service* service_;
  const CapInfo* cap_;
  Slot slot_;
};

// A subscription with uORB semantics (PX4 uORB::Subscription): the latest message is kept; `updated()`
// says whether one arrived since the last `copy()`. An optional callback runs on every delivery, in
// publish order, before `updated()` is visible to anyone else.
template <class T>
class Subscription {
 public:
  [[nodiscard]] bool updated() const { return state_->updated(); }
  // The latest message; marks it read. A zero-initialised T before the first delivery.
  const T& copy() const {
    state_->mark_read();
    return state_->latest();
  }
  // The latest message without marking it read.
  [[nodiscard]] const T& latest() const { return state_->latest(); }
  [[nodiscard]] bool valid() const { return state_->received() > 0; }
  // Broker generation of the latest message (0 = none yet).
  [[nodiscard]] std::uint64_t generation() const { return state_->generation(); }
  // Messages this subscriber missed because it fell more than the queue depth behind.
  [[nodiscard]] std::uint64_t lost() const { return state_->lost(); }
  [[nodiscard]] std::uint64_t received() const { return state_->received(); }
  [[nodiscard]] Slot slot() const { return state_->slot(); }

 private:
  friend class Service;
  explicit Subscription(detail::TypedSubscription<T>* state) : state_(state) {}
  detail::TypedSubscription<T>* state_;
};

// A kernel timer (docs/design.md §6: timers are kernel objects armed through the channel). A small handle; it
// does not cancel on destruction (timers usually live as long as the service): call cancel().
class Timer {
 public:
  SdkResult<void> cancel() const;
  [[nodiscard]] std::uint64_t id() const { return id_; }

 private:
  friend class Service;
  Timer(Service* service, std::uint64_t id) : service_(service), id_(id) {}
  Service* service_;
  std::uint64_t id_;
};

// ---- Kernel objects other than topics (docs/design.md §3) ----
// Typed handles, each resolved once by name and checked to be of its kind (Service::mode_control, limits,
// persistent, rejuvenation); small views, valid as long as the Service lives. Each call blocks for the
// kernel's Reply: a refusal comes back as Denied with the CapError, an operation failure as OperationFailed.

// The Mode object: asks the kernel for an SR mode (§V). The kernel enters whichever mode a holder of the
// cap asks for (no transition is checked: the policy decides who holds the cap, in which modes), applies
// that mode's caps, writes the time page and publishes sr_mode (docs/protocol.md "Invoke arguments").
class ModeControl {
 public:
  SdkResult<void> request(SrMode mode) const;

 private:
  friend class Service;
  ModeControl(Service* service, Slot slot) : service_(service), slot_(slot) {}
  Service* service_;
  Slot slot_;
};

// A Limits object: a record of restricted actuator limits, written by the service the policy lets write it
// and read by the driver that enforces it.
class LimitsCell {
 public:
  SdkResult<void> write(std::span<const std::byte> record) const;
  // The last record written, copied into `out` (truncated to its size); its size (0: none written yet).
  SdkResult<std::size_t> read(std::span<std::byte> out) const;

 private:
  friend class Service;
  LimitsCell(Service* service, Slot slot) : service_(service), slot_(slot) {}
  Service* service_;
  Slot slot_;
};

// A Persistent object: bytes that survive rollback (docs/design.md §3), read and written from its start.
class PersistentCell {
 public:
  // Up to out.size() bytes into `out`; how many were copied.
  SdkResult<std::size_t> read(std::span<std::byte> out) const;
  SdkResult<void> write(std::span<const std::byte> data) const;

 private:
  friend class Service;
  PersistentCell(Service* service, Slot slot) : service_(service), slot_(slot) {}
  Service* service_;
  Slot slot_;
};

// The Checkpoint object's rejuvenation side (docs/design.md §7–8): the timer that rolls the images back (§V-A
// do_timer) and a rollback asked for now. Checkpoints are taken with Service::checkpoint.
class Rejuvenation {
 public:
  // Fires `after` (> 0) from now, then every `period` (0: once); at most one arm per epoch. The kernel checks
  // both: a second arm is OperationFailed (Refused), a bad argument OperationFailed (BadArgument). Returns when
  // it is due (kernel clock).
  SdkResult<Nanos> arm_timer(Nanos after, Nanos period = Nanos{0}) const;
  // A rollback at the kernel's next safe point (this process is then retired: no answer comes back to it).
  SdkResult<void> roll_back() const;

 private:
  friend class Service;
  Rejuvenation(Service* service, Slot slot) : service_(service), slot_(slot) {}
  Service* service_;
  Slot slot_;
};

// How connect() finds its channel (tests may override; services use the defaults).
struct ConnectOptions {
  int channel_fd = wire::kChannelFd;
  int time_page_fd = wire::kTimePageFd;
};

// A service's connection to the kernel and its event loop.
//
// Params: the service's own `params` from the launch graph, plus these graph-wide ones that the kernel
// adds for every service (numbers unless marked text):
//   seed, clock (text: "lockstep" | "realtime"),
//   the keys of rejuv/core/graph_values.hpp: the SR scheme's (sr.*) and flight.start_s (the mission's t = 0 on
//   the kernel clock); durations as integer ns, read with graph_values::read(key, param_value(key.name)), which
//   gives the key's default for one the kernel does not send (an SR field a graph without SR leaves at 0),
//   mission.count, mission.acceptance_radius_m, mission.timeout_s,
//   mission.<i>.north_m, mission.<i>.east_m, mission.<i>.down_m, mission.<i>.yaw_rad  (i = 0 … count-1),
//   attack.enabled (0/1: the plan is on AND names this service), attack.count (attacks naming this
//   service), attack.<j>.kind (text: the AttackKind name, e.g. "WORST_CASE_CONTROL"), attack.<j>.start_s,
//   attack.<j>.max_windows, attack.<j>.magnitude (the attack library's size; 0 = the kind's default),
//   boot.cold_restarts (> 0: started by a cold restart).
class Service {
 public:
  static constexpr std::size_t kMaxTimers = clock::kMaxTimersPerService;  // the kernel's limit (docs/protocol.md)

  // Connects on fd 3 / fd 4: maps the time page read-only (the sandbox is the kernel's, installed before exec), sends
  // Hello, reads Boot…BootEnd. Does not send Ready: run() does that, after the service has made its
  // subscriptions and timers (docs/protocol.md "Boot").
  [[nodiscard]] static SdkResult<std::unique_ptr<Service>> connect(const ConnectOptions& options = {});

  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;
  Service(Service&&) = delete;
  Service& operator=(Service&&) = delete;
  ~Service();

  // ---- identity and time ----
  [[nodiscard]] std::string_view name() const;
  [[nodiscard]] ServiceId id() const;
  // Kernel clock (time page; lockstep: simulated time of the step being handled) [ns].
  [[nodiscard]] Nanos now() const;
  [[nodiscard]] SrMode mode() const;   // mode in force (time page)
  [[nodiscard]] Epoch epoch() const;   // rollback epoch (time page)

  // ---- params (launch graph) ----
  // A number param; an integer one (rejuv/core/graph_values.hpp: a duration in ns, a switch, a count) as a double.
  [[nodiscard]] double param(std::string_view name, double fallback) const;
  // A param as it crossed: a double or an integer; nullopt when absent, NaN for a text.
  [[nodiscard]] std::optional<graph_values::Value> param_value(std::string_view name) const;
  [[nodiscard]] std::string_view text_param(std::string_view name, std::string_view fallback) const;
  [[nodiscard]] bool has_param(std::string_view name) const;

  // ---- capabilities ----
  [[nodiscard]] std::span<const CapInfo> caps() const;
  // The boot-info entry of `object`: NoSuchObject when the policy never grants it to this service.
  [[nodiscard]] SdkResult<const CapInfo*> cap(std::string_view object) const;

  // ---- topics ----
  // The topic's cap must be a Topic of IDL type TopicTraits<T>::name and size sizeof(T), with Write in
  // some mode.
  template <class T>
  [[nodiscard]] SdkResult<Publisher<T>> advertise(std::string_view object);
  // Subscribes (a Subscribe request answered by the kernel; Read is needed in the current mode).
  // `on_message` (optional) runs on every delivery.
  template <class T>
  [[nodiscard]] SdkResult<Subscription<T>> subscribe(std::string_view object,
                                                     std::function<void(const T&)> on_message = {});
  // A polled subscription (PX4's uORB::Subscription, read with updated()/copy() from a timer or another
  // callback): its deliveries never wake this service. The kernel hands them over just before the next
  // frame that wakes it anyway, so whenever the service runs it sees the latest message, and a topic it
  // only samples (telemetry at 10 Hz of a 250 Hz estimate) costs it no wake-up per message.
  template <class T>
  [[nodiscard]] SdkResult<Subscription<T>> subscribe_polled(std::string_view object);

  // ---- topics of any type: a bridge that carries a topic as its IDL C struct's bytes (rejuv_host_link) ----
  // Subscribes to topic `object` whatever its type (CapInfo::type, CapInfo::payload_size): `on_message` gets each
  // delivery, exactly payload_size bytes, valid during the call. As subscribe: Read is needed in the current mode.
  [[nodiscard]] SdkResult<void> subscribe_untyped(std::string_view object,
                                                  std::function<void(std::span<const std::byte>)> on_message);
  // Publishes `payload` (exactly the topic's payload_size bytes) on topic `object` if the current mode grants
  // Write; otherwise NotHeldInMode and nothing is sent, as Publisher::publish.
  SdkResult<void> publish_untyped(std::string_view object, std::span<const std::byte> payload);

  // ---- timers (kernel clock) ----
  // Fires every `period` [ns of kernel time], first at now() + `phase` (default: one period).
  [[nodiscard]] SdkResult<Timer> every(Nanos period, std::function<void()> on_fire,
                                       std::optional<Nanos> phase = std::nullopt);
  // Fires once at now() + `delay`.
  [[nodiscard]] SdkResult<Timer> after(Nanos delay, std::function<void()> on_fire);
  SdkResult<void> cancel(const Timer& timer);

  // ---- other kernel objects (typed handles above; WrongObjectKind when `object` is of another kind) ----
  [[nodiscard]] SdkResult<ModeControl> mode_control(std::string_view object);
  [[nodiscard]] SdkResult<LimitsCell> limits(std::string_view object);
  [[nodiscard]] SdkResult<PersistentCell> persistent(std::string_view object);
  [[nodiscard]] SdkResult<Rejuvenation> rejuvenation(std::string_view object = "checkpoint");

  // ---- network (docs/design.md §2: the kernel's network gate, through a Network cap) ----
  // Runs `handler` for every datagram the kernel relays on the Network cap of `object` (NetDatagram frames:
  // only while the mode grants Read; the kernel drops the others). The bytes are untrusted and valid only
  // during the call. One handler per object; the cap must grant Read in some mode.
  [[nodiscard]] SdkResult<void> on_datagram(std::string_view object,
                                            std::function<void(std::span<const std::byte>)> handler);
  // Sends one datagram (1 … wire::kMaxDatagramBytes bytes) to the ground station through the Network cap of
  // `object` (NetSend; blocks for the kernel's Reply). NotHeldInMode, and nothing sent, when the current
  // mode grants no Write (an honest service causes no denial); OperationFailed(Refused) while no ground
  // station has sent anything.
  [[nodiscard]] SdkResult<void> send_datagram(std::string_view object, std::span<const std::byte> datagram);
  // True when the current mode grants Write on the cap of `object`.
  [[nodiscard]] bool may_send(std::string_view object) const;
  // Inside an on_datagram handler: tells the kernel what the datagram being handled was (NetReceive; once per
  // datagram). 0 = valid: its sender becomes the ground station that send_datagram reaches; 1 …
  // kernel_net_verdict_codes − 1 = refused, for that reason (counted by the kernel, in the run summary).
  // Until a valid datagram has been judged, send_datagram is Refused: garbage never redirects replies.
  static constexpr std::uint32_t kernel_net_verdict_codes = wire::kNetVerdictCodes;
  [[nodiscard]] SdkResult<void> judge_datagram(std::string_view object, std::uint32_t verdict);

  // ---- images (docs/design.md §7) ----
  // Takes checkpoint g through the Checkpoint cap of `object` (§V create_checkpoint). Like fork(), it
  // returns twice: `Taken{g}` in the live process, and `Restored{g, epoch}` when the image taken here is
  // resumed by a rollback (the rollback handler of §V-B runs on that return value, not on a semaphore).
  [[nodiscard]] SdkResult<CheckpointOutcome> checkpoint(std::string_view object = "checkpoint");

  // Starts a registered worker thread running `body`. Before a checkpoint the SDK parks every worker at
  // its next park_point(); the live process resumes them, a restored image starts each body again exactly
  // once (its old threads do not exist in the image). At most kMaxWorkers. Each is named kWorkerThreadName
  // (/proc/<pid>/task/<tid>/comm).
  static constexpr std::size_t kMaxWorkers = 8;
  static constexpr const char* kWorkerThreadName = "rejuv-worker";
  SdkResult<void> spawn_worker(std::function<void(WorkerContext&)> body);

  // ---- log ----
  // Printed by the kernel as "[name] text" (rate-limited per service). Text is cut at wire::kMaxLogText.
  void log(LogLevel level, std::string_view text);
  // A start-up check for main(): true when `result` holds a value; otherwise logs "<what>: <error>" at Error
  // level and returns false, so that `if (!svc.require(params, "bad params")) return 1;` is the whole check.
  template <class T, class E>
  [[nodiscard]] bool require(const Result<T, E>& result, std::string_view what) {
    if (result) return true;
    log(LogLevel::Error, std::string(what) + ": " + result.error().to_string());
    return false;
  }
  // require() over several results in order (e.g. every subscription, with what = "subscribe"): logs the
  // first failure only.
  template <class... R>
  [[nodiscard]] bool require_all(std::string_view what, const R&... results) {
    return (require(results, what) && ...);
  }
  void logf(LogLevel level, const char* format, ...) __attribute__((format(printf, 3, 4)));

  // ---- event loop ----
  // Sends Ready (first call only), then handles frames until Shutdown or stop(): deliveries run
  // subscription callbacks, TimerFired runs timer callbacks, and after each burst the SDK sends Idle
  // (lockstep). Returns the exit code: 0 after Shutdown, the stop() code, or 1 if the channel failed.
  [[nodiscard]] int run();
  // Makes run() return `exit_code` after the current callback.
  void stop(int exit_code);
  // Runs `fn` when Shutdown arrives, before run() returns.
  void on_shutdown(std::function<void()> fn);
  // Runs `fn` once in every restored incarnation (docs/design.md §7: a rollback resumed this process from one of its
  // images), with the epoch it was restored into — epoch() at that moment: the kernel has finished the
  // rollback — when the first frame of that incarnation arrives, before it is handled (a delivery, a timer):
  // so before any handler of the new epoch runs. (An
  // image taken inside a call, checkpoint(), returns from that call first: Restored{g, epoch}; the callback
  // follows once that handler returns.) Never in the process that took the image. One callback; a second call
  // replaces it. Register it before run(): the images then carry it.
  void on_restored(std::function<void(Epoch)> fn);

  // Frames a service sends (publish, log, timers) are queued and leave together when the event loop next
  // waits; flush() sends them now (e.g. before a long computation in a callback).
  SdkResult<void> flush();

  struct Impl;  // private state (channel, time page, boot info, queues), defined in src/

 private:
  friend class ModeControl;
  friend class LimitsCell;
  friend class PersistentCell;
  friend class Rejuvenation;
  template <class>
  friend class Publisher;
  friend class testing::RawAccess;

  explicit Service(std::unique_ptr<Impl> impl);
  // The slot of `object`'s cap, if it is of `kind` (NoSuchObject, WrongObjectKind).
  [[nodiscard]] SdkResult<Slot> object_slot(std::string_view object, ObjectKind kind) const;
  template <class Handle>
  [[nodiscard]] SdkResult<Handle> object_handle(std::string_view object, ObjectKind kind);  // service.cpp
  // Invoke on a slot: the wire's raw conventions (docs/protocol.md "Invoke"); blocks for the Reply (frames
  // that arrive meanwhile are queued and handled afterwards, in order). Reply data is copied into `out`.
  [[nodiscard]] SdkResult<InvokeReply> invoke_slot(Slot slot, cap::Operation op, std::uint64_t arg0 = 0,
                                                   std::uint64_t arg1 = 0, std::span<const std::byte> data = {},
                                                   std::span<std::byte> out = {});
  // Publish on a cap; `check_mode`: only if the current mode grants Write (NotHeldInMode otherwise).
  SdkResult<void> publish_bytes(const CapInfo& cap, std::span<const std::byte> payload, bool check_mode);
  SdkResult<Timer> arm_timer(Nanos first, Nanos period, std::function<void()> on_fire);
  [[nodiscard]] SdkResult<const CapInfo*> topic_cap(std::string_view object, std::string_view type,
                                                    std::size_t size, Right needed) const;
  [[nodiscard]] SdkResult<void> request_subscribe(const CapInfo& cap, bool polled);
  template <class T>
  [[nodiscard]] SdkResult<Subscription<T>> make_subscription(std::string_view object,
                                                             std::function<void(const T&)> on_message, bool polled);
  detail::SubscriptionBase* add_subscription(std::unique_ptr<detail::SubscriptionBase> sub);

  std::unique_ptr<Impl> impl_;
};

// ---- template definitions ----

template <class T>
SdkResult<void> Publisher<T>::publish(const T& message) const {
  static_assert(std::is_trivially_copyable_v<T>);
  return service_->publish_bytes(*cap_, std::as_bytes(std::span(&message, 1)), true);
}
template <class T>
bool Publisher<T>::allowed() const {
  return cap_->rights_in(service_->mode()).has(Right::Write);
}

template <class T>
SdkResult<Publisher<T>> Service::advertise(std::string_view object) {
  static_assert(std::is_trivially_copyable_v<T>);
  auto found = topic_cap(object, msgs::TopicTraits<T>::name, sizeof(T), Right::Write);
  if (!found) {
    return fail(std::move(found.error()));
  }
  return Publisher<T>(this, *found);
}

template <class T>
SdkResult<Subscription<T>> Service::subscribe(std::string_view object,
                                              std::function<void(const T&)> on_message) {
  return make_subscription<T>(object, std::move(on_message), false);
}

template <class T>
SdkResult<Subscription<T>> Service::subscribe_polled(std::string_view object) {
  return make_subscription<T>(object, {}, true);
}

template <class T>
SdkResult<Subscription<T>> Service::make_subscription(std::string_view object,
                                                      std::function<void(const T&)> on_message, bool polled) {
  static_assert(std::is_trivially_copyable_v<T>);
  auto found = topic_cap(object, msgs::TopicTraits<T>::name, sizeof(T), Right::Read);
  if (!found) {
    return fail(std::move(found.error()));
  }
  auto state = std::make_unique<detail::TypedSubscription<T>>((*found)->slot, (*found)->object,
                                                              std::move(on_message));
  auto* typed = state.get();
  if (auto sent = request_subscribe(**found, polled); !sent) {
    return fail(std::move(sent.error()));
  }
  add_subscription(std::move(state));
  return Subscription<T>(typed);
}

}  // namespace rejuv::sdk
