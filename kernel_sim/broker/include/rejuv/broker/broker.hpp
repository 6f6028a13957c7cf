// The kernel's message broker (docs/design.md §5): PX4 uORB queues (uORBDeviceNode semantics) as a pure in-process
// data structure, and their checkpoint state (docs/design.md §7). The paper (§IV-A) names the μORB queues as global
// state that a checkpoint must capture: messages queued but not yet read at the checkpoint are delivered
// again after a rollback, and nothing is lost or duplicated for a rolled-back service.
//
// Trust: the kernel decodes the publisher's / subscriber's capability before calling in (kernel_sim/cap);
// the broker checks only what is its own: the topic exists and the payload has exactly the topic's size.
// Not thread-safe: the kernel's event loop owns it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::broker {

// Position of a message in its topic's stream: the n-th publication on a topic has generation n (from 0).
// Not the checkpoint generation g of docs/design.md §7 (rejuv::Generation), hence its own type. A rollback sets a
// topic's counter back to its value at the checkpoint, so after a rollback a generation number is reused;
// pair it with the rollback epoch where uniqueness across rollbacks matters.
using TopicGeneration = StrongId<struct TopicGenerationTag, std::uint64_t>;

// Identity of one subscription. Never reused during a broker's life (a 64-bit counter that a restore does
// not rewind), so a stale id can never reach another subscription.
using SubscriberId = StrongId<struct SubscriberIdTag, std::uint64_t>;

// Limits on a topic's configuration.
inline constexpr std::uint32_t kMaxDepth = 1024;              // Q: messages per ring
inline constexpr std::size_t kMaxPayloadBytes = 64U * 1024U;  // one IDL struct; larger is a config error
inline constexpr std::uint32_t kMaxTopicObjectId = 65535;     // ObjectIds are dense kernel-object indices

// Why a broker operation was refused. A refused operation changes nothing (decode then invoke).
enum class BrokerError : std::uint8_t {
  BadConfig,          // create: empty name, payload size 0 or > kMaxPayloadBytes, depth not a power of two
                      // in 1..kMaxDepth, or object id > kMaxTopicObjectId
  DuplicateTopic,     // create: two topics with the same ObjectId or the same name
  UnknownTopic,       // no topic has this ObjectId
  WrongSize,          // publish: payload size differs from the topic's payload size
  UnknownSubscriber,  // no live subscription has this SubscriberId
  AlreadySubscribed,  // subscribe: this service already has a subscription on this topic
  SnapshotMismatch,   // restore: the snapshot was taken from a broker with other topics (or never taken)
};
[[nodiscard]] std::string_view to_string(BrokerError error);

// How a subscription behaves across a rollback (docs/design.md §7, paper §IV-C).
enum class SubscriberKind : std::uint8_t {
  Rejuvenated,  // its service is rolled back: the subscription and its cursor go back to the checkpoint
  Driver,       // driver level (output_driver), never rolled back: after a rollback it reads only what is
                // published after it, never the checkpoint's backlog again and never a generation that a
                // rollback erased
};
[[nodiscard]] std::string_view to_string(SubscriberKind kind);

// One topic of the broker, fixed at creation.
struct TopicConfig {
  ObjectId object{};             // the topic's kernel object (what caps name)
  std::string name{};            // e.g. "vehicle_state"; unique
  std::size_t payload_size = 0;  // sizeof the IDL struct [bytes]; every payload has exactly this size
  std::uint32_t depth = 1;       // Q: ring depth, a power of two in 1..kMaxDepth
};

// A rejected configuration: which error, which topic (index into the config list) and what was wrong.
struct ConfigError {
  BrokerError error = BrokerError::BadConfig;
  std::size_t topic_index = 0;
  std::string message{};
  [[nodiscard]] std::string to_string() const;  // "topic[i] 'name': message"
};

// One message handed to a subscriber. `payload` points into the topic's ring: valid until the next publish
// on that topic or the next restore (the kernel copies it to the subscriber's channel at once).
struct Delivery {
  std::span<const std::byte> payload{};
  TopicGeneration generation{};
  Nanos published_at{};    // the `t` given to publish (kernel clock)
  std::uint64_t lost = 0;  // messages this subscriber skipped since its previous delivery (ring overrun)
};

// Who to push to after a publish: one entry per subscription of a topic, ordered by SubscriberId.
struct Route {
  SubscriberId subscriber{};
  ServiceId service{};
  SubscriberKind kind = SubscriberKind::Rejuvenated;
  friend bool operator==(const Route&, const Route&) = default;
};

// Counters of the run. They measure what happened and are never rolled back (like the clock page, §6).
struct TopicStats {
  std::uint64_t published = 0;  // accepted publications since creation
  std::uint64_t lost = 0;       // sum over its subscribers of messages skipped by ring overrun
  friend bool operator==(const TopicStats&, const TopicStats&) = default;
};
struct SubscriberStats {
  std::uint64_t delivered = 0;
  std::uint64_t lost = 0;
  friend bool operator==(const SubscriberStats&, const SubscriberStats&) = default;
};

// What a restore did to the subscriptions, for the kernel's rollback log.
struct RestoreReport {
  std::size_t rejuvenated_restored = 0;   // rejuvenated subscriptions set back to their checkpoint cursor
  std::size_t rejuvenated_recreated = 0;  // of those, how many had been removed since the checkpoint
  std::size_t rejuvenated_dropped = 0;    // rejuvenated subscriptions created since the checkpoint, removed
  std::size_t drivers_rebased = 0;        // driver subscriptions whose cursor moved to the restored head
  std::size_t drivers_dropped = 0;        // driver subscriptions clashing with a restored one (restore)
};

// The broker's checkpoint state (docs/design.md §7 step 3): every ring's bytes (payloads and publish times), every
// topic's generation counter and every Rejuvenated subscription with its cursor. Driver subscriptions are
// not part of it: they are never rolled back (§IV-C). A value type, copyable, comparable; its storage is
// reused by Broker::snapshot_into, so a checkpoint after the first allocates nothing.
// The consistent cut of docs/design.md §7 needs nothing more: the kernel publishes the in-flight messages that
// belong before the cut (they land in the rings, undelivered) and then takes the snapshot, which is exact.
class BrokerSnapshot {
 public:
  BrokerSnapshot() = default;  // empty: restore refuses it (SnapshotMismatch)

  // Bytes held (rings + counters + subscriptions), for the checkpoint log.
  [[nodiscard]] std::size_t size_bytes() const;
  // Generation counter of each topic at the snapshot, in configuration order.
  [[nodiscard]] std::span<const std::uint64_t> heads() const { return heads_; }
  [[nodiscard]] std::size_t rejuvenated_subscribers() const { return subscribers_.size(); }

  friend bool operator==(const BrokerSnapshot&, const BrokerSnapshot&) = default;

 private:
  friend class Broker;
  // A Rejuvenated subscription as the checkpoint saw it.
  struct Subscription {
    SubscriberId id{};
    ServiceId service{};
    ObjectId topic{};
    std::uint64_t cursor = 0;  // next generation to deliver
    friend bool operator==(const Subscription&, const Subscription&) = default;
  };
  std::uint64_t layout_ = 0;                 // fingerprint of the topic configuration; 0 = never taken
  std::vector<std::byte> rings_{};           // the broker's ring arena, byte for byte
  std::vector<std::uint64_t> heads_{};       // per topic
  std::vector<Subscription> subscribers_{};  // ordered by id
};

// The broker: per topic a ring of depth Q (power of two) in one preallocated arena and a generation counter;
// per subscription a cursor (the next generation to deliver). A subscriber more than Q behind is clamped to
// the oldest message still in its ring and the skipped messages counted; a subscriber that stops reading
// never blocks publishers or other subscribers. Publish and delivery never allocate.
class Broker {
 public:
  [[nodiscard]] static Result<Broker, ConfigError> create(std::span<const TopicConfig> topics);

  Broker(Broker&&) noexcept = default;
  Broker& operator=(Broker&&) noexcept = default;
  Broker(const Broker&) = delete;  // the kernel's queue state exists once; snapshots are the copies
  Broker& operator=(const Broker&) = delete;
  ~Broker() = default;

  // ---- Data plane ----

  // Copies `payload` into the topic's ring at the topic's generation counter and advances it; returns the
  // generation written. UnknownTopic, WrongSize (payload.size() != the topic's payload size).
  [[nodiscard]] Result<TopicGeneration, BrokerError> publish(ObjectId topic,
                                                             std::span<const std::byte> payload, Nanos t);

  // The subscriber's next message in publish order, or nullopt when it has read everything.
  // UnknownSubscriber.
  [[nodiscard]] Result<std::optional<Delivery>, BrokerError> next(SubscriberId subscriber);

  // Messages `next` would deliver now (≤ Q). UnknownSubscriber.
  [[nodiscard]] Result<std::size_t, BrokerError> pending(SubscriberId subscriber) const;

  // ---- Subscriptions ----

  // A new subscription. Like uORB (uORBDeviceNode::get_initial_generation), a new subscriber is first given
  // the latest message already published, if any, and nothing older. UnknownTopic, AlreadySubscribed.
  [[nodiscard]] Result<SubscriberId, BrokerError> subscribe(ServiceId service, ObjectId topic,
                                                            SubscriberKind kind);
  // UnknownSubscriber.
  [[nodiscard]] Result<void, BrokerError> unsubscribe(SubscriberId subscriber);
  // Removes every subscription of a service (it died or was stopped); returns how many.
  std::size_t remove_service(ServiceId service);

  // The subscriptions of a topic, for routing after a publish. The span is valid until the next
  // subscribe, unsubscribe, remove_service or restore. UnknownTopic.
  [[nodiscard]] Result<std::span<const Route>, BrokerError> subscribers_of(ObjectId topic) const;

  // ---- Inspection ----

  [[nodiscard]] std::optional<ObjectId> find_topic(std::string_view name) const;
  // The generation the next publish on `topic` will get (= messages published, modulo rollbacks).
  [[nodiscard]] Result<TopicGeneration, BrokerError> head(ObjectId topic) const;
  [[nodiscard]] Result<TopicStats, BrokerError> topic_stats(ObjectId topic) const;
  [[nodiscard]] Result<SubscriberStats, BrokerError> subscriber_stats(SubscriberId subscriber) const;
  [[nodiscard]] Result<Route, BrokerError> subscriber(SubscriberId subscriber) const;
  [[nodiscard]] std::size_t topic_count() const { return topics_.size(); }
  [[nodiscard]] std::size_t subscriber_count() const { return subscribers_.size(); }

  // ---- Checkpoint state (docs/design.md §7) ----

  [[nodiscard]] BrokerSnapshot snapshot() const;
  // The same into existing storage: one memcpy for all rings; no allocation once `out` has held a
  // snapshot of this broker with at least as many rejuvenated subscriptions.
  void snapshot_into(BrokerSnapshot& out) const;

  // Rolls the queue state back to `snapshot` (SnapshotMismatch if it is not from a broker with this exact
  // topic configuration; nothing changes then). Afterwards:
  //  - every ring and generation counter is byte-for-byte as in the snapshot;
  //  - the Rejuvenated subscriptions are exactly those of the snapshot, with its cursors: one removed since
  //    (e.g. by remove_service when its service died) comes back under its old id, since the restored image
  //    of its service believes it is subscribed (§7 step 3 restores the services' kernel objects); one
  //    created since is removed, since the restored image predates it and will subscribe again if it
  //    needs to. Stats of a recreated subscription restart at zero;
  //  - Driver subscriptions stay as they are (never rolled back, §IV-C) and their cursor is set to the
  //    restored head: they get exactly what is published after the rollback. A Driver subscription on the
  //    same (service, topic) as a restored Rejuvenated one (a service whose kind changed — a kernel bug)
  //    is dropped so that the pair stays unique;
  //  - stats are not rolled back.
  // Hence restore(s) then snapshot() == s.
  [[nodiscard]] Result<RestoreReport, BrokerError> restore(const BrokerSnapshot& snapshot);

 private:
  struct Topic {
    ObjectId object{};
    std::string name{};
    std::size_t payload_size = 0;
    std::size_t stride = 0;  // bytes per ring slot: header + payload rounded up to kSlotAlign
    std::uint64_t depth = 1;
    std::size_t offset = 0;  // of the ring in the arena
    std::uint64_t head = 0;  // next generation to write
    TopicStats stats{};
    std::vector<Route> routes{};  // ordered by subscriber id
  };
  struct Subscriber {
    SubscriberId id{};
    ServiceId service{};
    std::uint32_t topic = 0;  // index into topics_
    SubscriberKind kind = SubscriberKind::Rejuvenated;
    std::uint64_t cursor = 0;  // next generation to deliver; ≤ the topic's head
    SubscriberStats stats{};
  };

  Broker() = default;
  [[nodiscard]] std::optional<std::uint32_t> topic_index(ObjectId object) const;
  [[nodiscard]] Subscriber* find(SubscriberId id);
  [[nodiscard]] const Subscriber* find(SubscriberId id) const;
  void rebuild_routes();
  // restore's steps: whether the snapshot matches this broker's layout and is coherent (decode), then the
  // subscription table rebuilt from the snapshot's Rejuvenated entries and the live Driver ones.
  [[nodiscard]] bool fits(const BrokerSnapshot& snap) const;
  RestoreReport merge_subscriptions(const BrokerSnapshot& snap);
  void take_saved(const BrokerSnapshot::Subscription& saved, RestoreReport& report);
  void keep_driver(const Subscriber& driver, const BrokerSnapshot& snap, RestoreReport& report);

  std::vector<Topic> topics_{};
  std::vector<std::uint32_t> topic_of_object_{};  // ObjectId value → index into topics_, or kNoTopic
  std::vector<std::byte> arena_{};                // every ring, one after the other
  std::vector<Subscriber> subscribers_{};         // ordered by id (ids are issued in increasing order)
  std::vector<Subscriber> scratch_{};             // restore builds the new table here, then swaps
  std::uint64_t next_subscriber_ = 0;
  std::uint64_t layout_ = 0;
};

}  // namespace rejuv::broker
