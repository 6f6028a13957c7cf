// The routing core (router.cpp) and the observers of what it routes (watch.cpp): publications into the broker
// and out to subscribers, the kernel's own messages, the DDS bridge's samples, the output to each service
// under flow control, the mission watch and the capability system's denials. Owns the subscribers' table, the
// output batch of a round and the mission watch.
#pragma once

#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

#include "mission_watch.hpp"
#include "output_batch.hpp"
#include "rejuv/broker/broker.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/core/rate_budget.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "service_runtime.hpp"
#include "vocabulary.hpp"

namespace rejuv::kernel {

// A message of the kernel's own (SrMode, RollbackSignal, SecurityEvent) over zeroed bytes: its padding is zero,
// so what is published is the same in every run and carries nothing of the kernel's memory. Zeroed by memset:
// GCC 12 leaves a value-initialised RollbackSignal's tail padding as it was (router_parts_test.cpp).
template <typename T>
struct KernelMessage {
  static_assert(std::is_trivially_copyable_v<T>);
  KernelMessage() { std::memset(&fields, 0, sizeof fields); }
  T fields;
};

class Router {
 public:
  explicit Router(Kernel::Impl& kernel) : k(kernel) {}

  // By SubscriberId value: whose subscription it is, its slot, and how many messages were routed to it
  // (routed − delivered − pending = lost, counted even while it stays blocked and never calls next()).
  struct SubscriberInfo {
    ServiceId service{};
    Slot slot{};
    std::uint64_t routed = 0;
    bool polled = false;  // wire::kSubscribePolled
  };
  void add_subscriber(broker::SubscriberId id, SubscriberInfo info);  // a Subscribe the broker accepted
  [[nodiscard]] std::optional<std::uint64_t> routed_to(broker::SubscriberId id) const;

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
  void publish_kernel_message(const KernelMessage<T>& message) {
    publish_kernel_bytes(msgs::TopicTraits<T>::name, std::as_bytes(std::span(&message.fields, 1)));
  }
  // A SecurityEvent (docs/design.md §3): every capability denial, forbidden call, stray process and lost image.
  void publish_security_event(Nanos at, ServiceId service, std::uint32_t slot, rejuv_msg_SecurityEventKind kind,
                              SrMode mode, std::uint8_t operation = 0, std::uint8_t error = 0);
  void finish_routes(ObjectId topic);  // pushes the topic's newest message to every subscriber
  void flush_staged();
  void route_samples();
  void publish_sr_mode();
  [[nodiscard]] bool sr_mode_announced() const { return mode_announced; }  // an SrMode published this run
  bool write_to_bridge(ObjectId topic, std::span<const std::byte> payload);  // false: the run stops
  // Output to a service (flow control: FlowControl, service_runtime.hpp, keeps the order, the pool, the
  // count).
  void push_ring(ServiceRuntime& s, broker::SubscriberId subscriber);
  // What the polled subscriptions of `s` have pending, pushed ahead of a frame that wakes `s` anyway.
  void hand_over_polled(ServiceRuntime& s);
  void send_control(ServiceRuntime& s, std::span<const std::byte> frame);
  void drain(ServiceRuntime& s);
  // Whether `s` is over its publication budget now (docs/sandbox.md "Floods cost only the flooder"): its last
  // publication was dropped and its bucket has not refilled 1 % of its burst since.
  [[nodiscard]] bool dropping(const ServiceRuntime& s);
  // What the other owners tell the Router about a service's channel (its FlowControl is the Router's alone):
  // an Idle: what it reports handled
  void on_idle(ServiceRuntime& s, std::uint64_t frames_received) { s.flow_.on_idle(frames_received); }
  // a polled subscription of `s` has news (handed over at its next wake-up)
  void note_polled(ServiceRuntime& s) { s.flow_.note_polled(); }
  // a frame another owner sent on the channel itself (a Snapshot with its fds)
  void count_sent(ServiceRuntime& s) { s.flow_.count_sent(); }
  // every subscription drained once its out-queue empties (routing resumed)
  void request_sweep(ServiceRuntime& s) { s.flow_.request_sweep(); }
  // a spawn or a restored image: its Idle count restarts
  void channel_opened(ServiceRuntime& s) { s.flow_.new_channel(); }
  // a death or a retired incarnation: nothing waits, nothing is held
  void channel_closed(ServiceRuntime& s) { s.flow_.reset(); }
  void new_step();  // lockstep: every service's publication bound starts again
  void cork();    // opens the output batch (output_batch.hpp) for a routing round
  void uncork();  // closes it and flushes every service's frames
  void set_writable_interest(ServiceRuntime& s, bool want);

  // ---- observers of the routed traffic (watch.cpp, mission_watch.hpp) ----
  void drain_denials();  // the capability system's new denials: counted, logged, published as SecurityEvents

 private:
  // The one hook of the routing core (watch.cpp): every publication routed, the service's or the kernel's own.
  void watch_publication(const ObjectInfo& o, std::span<const std::byte> payload, broker::TopicGeneration g,
                         std::optional<ServiceId> publisher);
  void publish_kernel_bytes(std::string_view type_name, std::span<const std::byte> message);
  void after_publish(ObjectId topic, std::span<const std::byte> payload, broker::TopicGeneration g,
                     std::optional<ServiceId> publisher, From from);
  void uncork_service(ServiceRuntime& s);
  enum class SendResult : std::uint8_t { Sent, Blocked, Failed };
  SendResult send_now(ServiceRuntime& s, std::span<const std::byte> frame);
  bool deliver_one(ServiceRuntime& s, broker::SubscriberId subscriber);  // false: nothing pending or blocked
  // A service's publication budget (docs/sandbox.md "Floods cost only the flooder"): false = over it, the
  // publication dropped and counted; reported (log line, SecurityEvent) at most once per kReportEvery.
  bool within_budget(ServiceRuntime& s, std::uint32_t slot);
  struct PublicationBudget {
    RateBudget rate{};
    Nanos next_report{0};
    std::uint64_t reported = 0;  // drops already said in a report
    bool dropping = false;       // its last publication was over budget
  };
  static constexpr Nanos kReportEvery{std::chrono::seconds{1}};

  Kernel::Impl& k;
  std::vector<SubscriberInfo> subscribers;  // by SubscriberId value
  std::vector<std::optional<PublicationBudget>> budgets;  // by ServiceId value, made at its first publication
  MissionWatch mission;                     // watch.cpp
  OutputBatch batch;  // a routing round's output (cork/uncork)
  wire::FrameBuffer
      deliver_tx;  // Deliver frames (deliver_one), which may go out while a control frame is in tx
  std::uint64_t denials_drained = 0;
  bool mode_announced = false;
};

}  // namespace rejuv::kernel
