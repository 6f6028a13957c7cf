// The kernel's private state (kernel.hpp lists the files of kernel_sim/kernel/src): the run's configuration,
// the components every owner uses, the services, and the owners that compose the kernel. Each member below
// names its owner — the one that writes it; the others read.
//
//   Supervisor   supervisor.hpp    spawning, the Boot, losing a service, deadlines, shutdown, the plant
//   ChannelInput channel_input.hpp the frames of the services' channels, decoded and handled
//   Router       router.hpp        routing, output under flow control, the mission watch, the denials
//   Lockstep     lockstep.hpp      the steps, their rounds and samples, the pace, the stop conditions
//   Rejuvenator  rejuvenator.hpp   checkpoints, rollbacks, the image work, the rejuvenation timer (docs/design.md §7)
//   Warden       warden.hpp        seccomp notices, the services' output, the strays, violations
//
// What stays here: the loop (loop.cpp), the network gate (netgate.cpp) and the logging and time every owner
// uses.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "bridge.hpp"
#include "channel_input.hpp"
#include "invocation.hpp"
#include "kernel_clock.hpp"
#include "lockstep.hpp"
#include "netgate.hpp"
#include "rejuv/broker/broker.hpp"
#include "rejuv/cap/cap_system.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/clock/timers.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/policy/policy.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/lease.hpp"
#include "rejuv/sys/subid.hpp"
#include "rejuv/sys/seccomp.hpp"
#include "rejuvenator.hpp"
#include "router.hpp"
#include "service_runtime.hpp"
#include "supervisor.hpp"
#include "vocabulary.hpp"
#include "warden.hpp"

namespace rejuv::kernel {

// What the Warden asks of the other owners (warden.hpp), answered from this kernel's (owner_peers.cpp).
class KernelWardenPeers final : public WardenPeers {
 public:
  explicit KernelWardenPeers(Kernel::Impl& kernel) : k(kernel) {}
  [[nodiscard]] Nanos now() const override;
  [[nodiscard]] Nanos wall() const override;
  [[nodiscard]] SrMode mode() const override;
  [[nodiscard]] bool rolls_back_on_violation() const override;
  void log(const std::string& line) override;
  void service_log(ServiceRuntime& s, std::string_view line) override;
  void publish_security_event(ServiceId s, std::uint32_t detail, rejuv_msg_SecurityEventKind kind) override;
  void request_rollback(std::string reason) override;
  void for_each_image(const std::function<void(const image::Image&)>& f) const override;
  [[nodiscard]] bool knows_child(pid_t pid) const override;
  void settle_images() override;
  [[nodiscard]] bool checkpoint_running() const override;
  [[nodiscard]] bool owes_image(ServiceId s) const override;
  [[nodiscard]] bool take_unheard_copy(ServiceId s) override;
  void kill_and_reap_later(sys::ChildProcess p) override;

 private:
  Kernel::Impl& k;
};

struct Kernel::Impl {
  // ---- configuration: written once, by create.cpp ----
  launch::LoadedLaunch graph;
  KernelOptions options;
  Observer* observer = nullptr;
  policy::Policy policy;
  ClockMode clock_mode = ClockMode::Lockstep;
  bool sr = false;
  std::uint64_t seed = 1;
  std::uint32_t domain = 0;
  dds::RunId run_id{};  // the DDS partition of the bridge and the plant (KernelOptions::run_id)
  std::optional<int> pinned_cpu;  // KernelOptions::placement: the CPU of the whole run, if pinned
  // As root, service i runs as sys::service_uid(*uid_block, i), from a block this kernel alone holds; without
  // root (strict sandbox), as subordinate_ids->ids_of(i), from a block of the user's subordinate ids.
  std::optional<sys::Lease> uid_block;
  std::optional<sys::SubordinateBlock> subordinate_ids;
  std::vector<msgs::TopicType> declared_types;  // the policy's own (`types`), pointed to by objects
  // By ObjectId. Persistent cells and Limits data written by ChannelInput (their invocations).
  std::vector<ObjectInfo> objects;

  // ---- components, each its own owner (their headers) ----
  cap::CapSystem caps;
  broker::Broker broker;
  KernelClock kernel_clock;  // the time page's one writer: set_now and the Rejuvenator's epochs
  clock::TimerTable timers;
  std::optional<sys::SeccompProgram> seccomp;
  std::optional<sys::SeccompProgram> link_seccomp;  // the links' (network_service_policy), when there is a link
  std::optional<sys::SignalFd> signals;
  sys::Epoll epoll;
  std::optional<sys::TimerFd> timerfd;
  std::optional<DdsBridge> bridge;  // DDS, and the plant's lockstep adapter (bridge.hpp)
  NetGate net;                      // the network gate, changed through its methods (netgate.hpp)

  // By ServiceId: each service's runtime, by concern (service_runtime.hpp); its process and phase written by
  // the Supervisor and the Rejuvenator, its flow by the Router alone (the others read it through flow() and tell
  // the Router what happened), its channel state by the ChannelInput.
  std::vector<ServiceRuntime> services;

  // ---- the owners (in this order: destroyed in reverse) ----
  Router router{*this};
  Supervisor supervisor{*this};
  Lockstep lockstep{*this};
  Rejuvenator rejuvenator{*this};
  KernelWardenPeers warden_peers{*this};
  Warden warden{WardenParts{.graph = graph.graph,
                            .options = options,
                            .clock_mode = clock_mode,
                            .services = services,
                            .epoll = epoll},
                warden_peers};
  ChannelInput input{*this};

  // ---- run state: Kernel::run and the scripted runs (kernel.cpp, scripted.cpp), the loop, shutdown_all ----
  bool booted = false;             // every service Ready (Kernel::run, scripted.cpp)
  bool shut_down = false;          // Supervisor::shutdown_all
  bool stopping = false;           // Supervisor::shutdown_all
  std::optional<StopReason> stop;  // stop_run
  std::string stop_detail;         // stop_run
  Nanos run_start_mono{0};         // the loop
  bool clock_synced =
      true;             // the loop: in real time with a plant, the kernel clock follows the plant's samples
  Nanos wall_start{0};  // Kernel::run, scripted.cpp
  Nanos last_progress{0};               // Kernel::run, the loop
  std::uint64_t kernel_bad_frames = 0;  // refuse
  wire::FrameBuffer tx;  // control frames (Reply, TimerFired, Boot …) of any owner, passed to send_control

  Impl(launch::LoadedLaunch g, KernelOptions o, Observer* obs, policy::Policy p, cap::CapSystem c, broker::Broker b,
       clock::TimePageWriter tp, std::size_t service_count, sys::Epoll e)
      : graph(std::move(g)), options(std::move(o)), observer(obs), policy(std::move(p)), caps(std::move(c)),
        broker(std::move(b)), kernel_clock(std::move(tp), caps.mode()), timers(service_count), epoll(std::move(e)) {}

  // ---- logging and time (loop.cpp) ----
  void log(const char* format, ...) __attribute__((format(printf, 2, 3)));
  void service_log(ServiceRuntime& s, wire::LogLevel level, std::string_view text);
  void refuse(ServiceRuntime& s, std::string_view what);  // counts and logs (rate-limited) a bad frame
  [[nodiscard]] Nanos now() const { return kernel_clock.now(); }
  void set_now(Nanos t);  // the kernel clock and the capability system's time
  [[nodiscard]] Nanos wall() const;
  void stop_run(StopReason reason, std::string detail);

  // ---- the loop (loop.cpp) ----
  [[nodiscard]] Result<void, KernelError> pump(std::optional<Nanos> max_wait);
  [[nodiscard]] Result<void, KernelError> run_realtime();  // Kernel::run with the realtime clock
  void on_dds_ready(std::size_t reader);
  void sync_realtime_clock(std::span<const std::byte> first_sample);
  void fire_timers();
  void arm_timerfd();
  [[nodiscard]] bool all_idle() const;
  [[nodiscard]] bool all_ready() const;
  [[nodiscard]] std::optional<Nanos> next_wall_deadline() const;
  // Real time: the replay handed on a few instants at a time while the chain's channels keep up, then ended
  // once the chain has handled it all (Sync → Idle; its outputs held from the others until then).
  void pace_catch_up();
  void cut_catch_up_short();  // the replay past the kernel's bound: REARM, the live samples out (loop.cpp)
  void drain_catch_up();      // real time, after a cut: the chain's real-time plan back once it is idle
  bool chain_answered();      // real time: every live service of the catch-up chain idle; a Sync to each that owes one
  // A Sync to `s` (docs/protocol.md "Idle": it answers with an Idle once it has handled what came before); false
  // when the frame could not be built.
  bool ask_idle(ServiceRuntime& s);

  // ---- network gate (netgate.cpp) ----
  // Opens the UDP socket of the launch graph's `network` (at create; realtime: registered in epoll).
  [[nodiscard]] Result<void, KernelError> net_open();
  // Reads up to kDatagramsPerPoll queued datagrams and relays or drops each (realtime: on wakeup;
  // lockstep: at the start of each step, so that what a service sees does not depend on scheduling).
  void net_poll();
  // NetSend / NetReceive invocations, decoded and their authority checked (ChannelInput): sends a datagram,
  // or records the receiver's verdict on a relayed one (NetDatagram aux).
  void net_invoke(ServiceRuntime& s, std::uint32_t seq, const cap::Invocation& authority,
                  const NetInvocation& what);
};

}  // namespace rejuv::kernel
