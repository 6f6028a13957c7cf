// uORB queues and their checkpoint state (docs/design.md §5, §7; paper §IV-A, §IV-C). See broker.hpp.
#include "rejuv/broker/broker.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>
#include <utility>

namespace rejuv::broker {
namespace {

constexpr std::uint32_t kNoTopic = std::numeric_limits<std::uint32_t>::max();

// A ring slot is [header | payload | padding to kSlotAlign]. The header keeps the publish time and the
// generation written there, so a delivery carries its time and a ring bug is caught by an assert rather
// than delivered as the wrong message. Payloads start 16-byte aligned (malloc's alignment on x86-64 and
// AArch64) so that a reader may view one in place as its IDL struct.
constexpr std::size_t kSlotAlign = 16;
struct SlotHeader {
  std::int64_t published_at_ns = 0;
  std::uint64_t generation = 0;
};
constexpr std::size_t kHeaderBytes = sizeof(SlotHeader);
static_assert(kHeaderBytes % kSlotAlign == 0);

constexpr std::size_t round_up(std::size_t n, std::size_t to) {
  return (n + to - 1) / to * to;
}

// FNV-1a over the configuration that determines the arena's layout: a snapshot restores only into a broker
// with the same topics, sizes and depths in the same order. Never 0 (0 marks an empty snapshot).
class Fingerprint {
 public:
  void add(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) {
      hash_ ^= (v >> (8 * i)) & 0xFFU;
      hash_ *= 0x100000001b3ULL;
    }
  }
  [[nodiscard]] std::uint64_t value() const { return hash_ == 0 ? 1 : hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

SlotHeader read_header(const std::byte* slot) {
  SlotHeader h;
  std::memcpy(&h, slot, sizeof h);
  return h;
}

}  // namespace

std::string_view to_string(BrokerError error) {
  switch (error) {
    case BrokerError::BadConfig: return "BadConfig";
    case BrokerError::DuplicateTopic: return "DuplicateTopic";
    case BrokerError::UnknownTopic: return "UnknownTopic";
    case BrokerError::WrongSize: return "WrongSize";
    case BrokerError::UnknownSubscriber: return "UnknownSubscriber";
    case BrokerError::AlreadySubscribed: return "AlreadySubscribed";
    case BrokerError::SnapshotMismatch: return "SnapshotMismatch";
  }
  return "BrokerError(?)";
}

std::string_view to_string(SubscriberKind kind) {
  switch (kind) {
    case SubscriberKind::Rejuvenated: return "Rejuvenated";
    case SubscriberKind::Driver: return "Driver";
  }
  return "SubscriberKind(?)";
}

std::string ConfigError::to_string() const {
  return "topic[" + std::to_string(topic_index) + "]: " + std::string(broker::to_string(error)) + ": " +
         message;
}

std::size_t BrokerSnapshot::size_bytes() const {
  return rings_.size() + heads_.size() * sizeof(std::uint64_t) + subscribers_.size() * sizeof(Subscription);
}

// ---- Creation ----

Result<Broker, ConfigError> Broker::create(std::span<const TopicConfig> topics) {
  // Decode: check every topic before building anything.
  std::uint32_t max_object = 0;
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const TopicConfig& c = topics[i];
    const auto bad = [&](BrokerError e, std::string what) {
      return fail(
          ConfigError{.error = e, .topic_index = i, .message = "'" + c.name + "': " + std::move(what)});
    };
    if (c.name.empty()) {
      return bad(BrokerError::BadConfig, "empty topic name");
    }
    if (c.payload_size == 0 || c.payload_size > kMaxPayloadBytes) {
      return bad(BrokerError::BadConfig, "payload size " + std::to_string(c.payload_size) + " not in 1.." +
                                             std::to_string(kMaxPayloadBytes));
    }
    if (c.depth == 0 || c.depth > kMaxDepth || !std::has_single_bit(c.depth)) {
      return bad(BrokerError::BadConfig, "depth " + std::to_string(c.depth) +
                                             " is not a power of two in 1.." + std::to_string(kMaxDepth));
    }
    if (c.object.value() > kMaxTopicObjectId) {
      return bad(BrokerError::BadConfig,
                 "object id " + std::to_string(c.object.value()) + " > " + std::to_string(kMaxTopicObjectId));
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (topics[j].object == c.object) {
        return bad(BrokerError::DuplicateTopic, "object id " + std::to_string(c.object.value()) +
                                                    " already used by topic[" + std::to_string(j) + "]");
      }
      if (topics[j].name == c.name) {
        return bad(BrokerError::DuplicateTopic, "name already used by topic[" + std::to_string(j) + "]");
      }
    }
    max_object = std::max(max_object, c.object.value());
  }

  // Invoke: lay every ring out in one arena (preallocated once; publish never allocates, §5).
  Broker b;
  b.topics_.reserve(topics.size());
  b.topic_of_object_.assign(topics.empty() ? 0 : std::size_t{max_object} + 1, kNoTopic);
  Fingerprint fp;
  std::size_t offset = 0;
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const TopicConfig& c = topics[i];
    const std::size_t stride = kHeaderBytes + round_up(c.payload_size, kSlotAlign);
    b.topics_.push_back(Topic{.object = c.object,
                              .name = c.name,
                              .payload_size = c.payload_size,
                              .stride = stride,
                              .depth = c.depth,
                              .offset = offset,
                              .head = 0,
                              .stats = {},
                              .routes = {}});
    b.topic_of_object_[c.object.value()] = static_cast<std::uint32_t>(i);
    offset += stride * c.depth;
    fp.add(c.object.value());
    fp.add(c.payload_size);
    fp.add(c.depth);
  }
  b.arena_.assign(offset, std::byte{0});
  REJUV_ASSERT(reinterpret_cast<std::uintptr_t>(b.arena_.data()) % kSlotAlign == 0, "ring arena alignment");
  b.layout_ = fp.value();
  return b;
}

// ---- Lookups ----

std::optional<std::uint32_t> Broker::topic_index(ObjectId object) const {
  const std::uint32_t v = object.value();
  if (v >= topic_of_object_.size() || topic_of_object_[v] == kNoTopic) {
    return std::nullopt;
  }
  return topic_of_object_[v];
}

// Subscriptions are few (~35 in the real graph) and ordered by id: a binary search is a handful of compares
// and keeps ids stable and never reused (a slot map would reuse slots across a restore).
Broker::Subscriber* Broker::find(SubscriberId id) {
  return const_cast<Subscriber*>(
      std::as_const(*this).find(id));  // NOLINT(cppcoreguidelines-pro-type-const-cast)
}

const Broker::Subscriber* Broker::find(SubscriberId id) const {
  const auto it = std::lower_bound(subscribers_.begin(), subscribers_.end(), id,
                                   [](const Subscriber& s, SubscriberId v) { return s.id < v; });
  return it != subscribers_.end() && it->id == id ? &*it : nullptr;
}

std::optional<ObjectId> Broker::find_topic(std::string_view name) const {
  for (const Topic& t : topics_) {
    if (t.name == name) {
      return t.object;
    }
  }
  return std::nullopt;
}

Result<TopicGeneration, BrokerError> Broker::head(ObjectId topic) const {
  const auto idx = topic_index(topic);
  if (!idx) {
    return fail(BrokerError::UnknownTopic);
  }
  return TopicGeneration{topics_[*idx].head};
}

Result<TopicStats, BrokerError> Broker::topic_stats(ObjectId topic) const {
  const auto idx = topic_index(topic);
  if (!idx) {
    return fail(BrokerError::UnknownTopic);
  }
  return topics_[*idx].stats;
}

Result<SubscriberStats, BrokerError> Broker::subscriber_stats(SubscriberId subscriber) const {
  const Subscriber* s = find(subscriber);
  if (s == nullptr) {
    return fail(BrokerError::UnknownSubscriber);
  }
  return s->stats;
}

Result<Route, BrokerError> Broker::subscriber(SubscriberId subscriber) const {
  const Subscriber* s = find(subscriber);
  if (s == nullptr) {
    return fail(BrokerError::UnknownSubscriber);
  }
  return Route{.subscriber = s->id, .service = s->service, .kind = s->kind};
}

Result<std::span<const Route>, BrokerError> Broker::subscribers_of(ObjectId topic) const {
  const auto idx = topic_index(topic);
  if (!idx) {
    return fail(BrokerError::UnknownTopic);
  }
  return std::span<const Route>(topics_[*idx].routes);
}

// ---- Data plane ----

Result<TopicGeneration, BrokerError> Broker::publish(ObjectId topic, std::span<const std::byte> payload,
                                                     Nanos t) {
  const auto idx = topic_index(topic);
  if (!idx) {
    return fail(BrokerError::UnknownTopic);
  }
  Topic& tp = topics_[*idx];
  if (payload.size() != tp.payload_size) {
    return fail(BrokerError::WrongSize);
  }
  // Overwrites the oldest message when the ring is full: a subscriber that stops reading never blocks the
  // publisher (uORB); it finds out through `lost` when it reads again.
  const std::uint64_t g = tp.head;
  std::byte* slot = arena_.data() + tp.offset + (g & (tp.depth - 1)) * tp.stride;
  const SlotHeader h{.published_at_ns = t.count(), .generation = g};
  std::memcpy(slot, &h, sizeof h);
  std::memcpy(slot + kHeaderBytes, payload.data(), payload.size());
  tp.head = g + 1;
  ++tp.stats.published;
  return TopicGeneration{g};
}

Result<std::optional<Delivery>, BrokerError> Broker::next(SubscriberId subscriber) {
  Subscriber* s = find(subscriber);
  if (s == nullptr) {
    return fail(BrokerError::UnknownSubscriber);
  }
  Topic& tp = topics_[s->topic];
  REJUV_ASSERT(s->cursor <= tp.head, "subscriber cursor beyond its topic's head");
  if (s->cursor == tp.head) {
    return std::optional<Delivery>{};
  }
  // More than Q behind: the messages before head − Q were overwritten; clamp to the oldest still in the
  // ring and count the skipped ones (uORBDeviceNode::copy).
  std::uint64_t lost = 0;
  if (tp.head - s->cursor > tp.depth) {
    const std::uint64_t oldest = tp.head - tp.depth;
    lost = oldest - s->cursor;
    s->cursor = oldest;
    s->stats.lost += lost;
    tp.stats.lost += lost;
  }
  const std::uint64_t g = s->cursor;
  const std::byte* slot = arena_.data() + tp.offset + (g & (tp.depth - 1)) * tp.stride;
  const SlotHeader h = read_header(slot);
  REJUV_ASSERT(h.generation == g, "ring slot does not hold the generation its position implies");
  s->cursor = g + 1;
  ++s->stats.delivered;
  return Delivery{.payload = std::span<const std::byte>(slot + kHeaderBytes, tp.payload_size),
                  .generation = TopicGeneration{g},
                  .published_at = Nanos{h.published_at_ns},
                  .lost = lost};
}

Result<std::size_t, BrokerError> Broker::pending(SubscriberId subscriber) const {
  const Subscriber* s = find(subscriber);
  if (s == nullptr) {
    return fail(BrokerError::UnknownSubscriber);
  }
  const Topic& tp = topics_[s->topic];
  return static_cast<std::size_t>(std::min(tp.head - s->cursor, tp.depth));
}

// ---- Subscriptions ----

Result<SubscriberId, BrokerError> Broker::subscribe(ServiceId service, ObjectId topic, SubscriberKind kind) {
  const auto idx = topic_index(topic);
  if (!idx) {
    return fail(BrokerError::UnknownTopic);
  }
  Topic& tp = topics_[*idx];
  for (const Route& r : tp.routes) {
    if (r.service == service) {
      return fail(BrokerError::AlreadySubscribed);
    }
  }
  const SubscriberId id{next_subscriber_++};
  // uORB's initial generation: the latest message, if one exists, is pending for a new subscriber — a
  // late subscriber to a rarely published topic (mission, sr_mode) still gets the current value.
  const std::uint64_t cursor = tp.head == 0 ? 0 : tp.head - 1;
  subscribers_.push_back(
      Subscriber{.id = id, .service = service, .topic = *idx, .kind = kind, .cursor = cursor, .stats = {}});
  tp.routes.push_back(Route{.subscriber = id, .service = service, .kind = kind});
  // Keep restore's working table as large as the live one, so a rollback does not allocate.
  scratch_.reserve(subscribers_.capacity());
  return id;
}

Result<void, BrokerError> Broker::unsubscribe(SubscriberId subscriber) {
  const Subscriber* s = find(subscriber);
  if (s == nullptr) {
    return fail(BrokerError::UnknownSubscriber);
  }
  std::erase_if(topics_[s->topic].routes, [&](const Route& r) { return r.subscriber == subscriber; });
  subscribers_.erase(subscribers_.begin() + (s - subscribers_.data()));
  return {};
}

std::size_t Broker::remove_service(ServiceId service) {
  const std::size_t removed =
      std::erase_if(subscribers_, [&](const Subscriber& s) { return s.service == service; });
  if (removed != 0) {
    rebuild_routes();
  }
  return removed;
}

void Broker::rebuild_routes() {
  for (Topic& t : topics_) {
    t.routes.clear();  // keeps capacity
  }
  for (const Subscriber& s : subscribers_) {
    topics_[s.topic].routes.push_back(Route{.subscriber = s.id, .service = s.service, .kind = s.kind});
  }
}

// ---- Checkpoint state ----

BrokerSnapshot Broker::snapshot() const {
  BrokerSnapshot s;
  snapshot_into(s);
  return s;
}

void Broker::snapshot_into(BrokerSnapshot& out) const {
  out.layout_ = layout_;
  // The rings are contiguous: one copy for all of them. resize() reuses out's storage (same layout).
  out.rings_.resize(arena_.size());
  if (!arena_.empty()) {
    std::memcpy(out.rings_.data(), arena_.data(), arena_.size());
  }
  out.heads_.resize(topics_.size());
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    out.heads_[i] = topics_[i].head;
  }
  out.subscribers_.clear();
  for (const Subscriber& s : subscribers_) {
    switch (s.kind) {
      case SubscriberKind::Rejuvenated:
        out.subscribers_.push_back(BrokerSnapshot::Subscription{
            .id = s.id, .service = s.service, .topic = topics_[s.topic].object, .cursor = s.cursor});
        break;
      case SubscriberKind::Driver: break;  // never rolled back (§IV-C): not checkpoint state
    }
  }
}

Result<RestoreReport, BrokerError> Broker::restore(const BrokerSnapshot& snap) {
  if (!fits(snap)) {
    return fail(BrokerError::SnapshotMismatch);
  }

  // Invoke: rings and generation counters back to the checkpoint (§IV-A: the queued messages are state).
  if (!arena_.empty()) {
    std::memcpy(arena_.data(), snap.rings_.data(), arena_.size());
  }
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    topics_[i].head = snap.heads_[i];
  }
  const RestoreReport report = merge_subscriptions(snap);
  rebuild_routes();
  return report;
}

bool Broker::fits(const BrokerSnapshot& snap) const {
  // Decode: the snapshot must come from a broker with this exact layout, and every saved subscription must
  // be coherent with it. Nothing changes unless all of it holds.
  if (snap.layout_ != layout_ || snap.rings_.size() != arena_.size() ||
      snap.heads_.size() != topics_.size()) {
    return false;
  }
  for (std::size_t i = 0; i < snap.subscribers_.size(); ++i) {
    const BrokerSnapshot::Subscription& s = snap.subscribers_[i];
    const auto idx = topic_index(s.topic);
    if (!idx || s.cursor > snap.heads_[*idx] || s.id.value() >= next_subscriber_ ||
        (i > 0 && !(snap.subscribers_[i - 1].id < s.id))) {
      return false;
    }
  }
  return true;
}

RestoreReport Broker::merge_subscriptions(const BrokerSnapshot& snap) {
  // Subscriptions: merge, by id, the snapshot's Rejuvenated ones with the live Driver ones (both tables are
  // ordered by id).
  RestoreReport report;
  scratch_.clear();
  auto saved = snap.subscribers_.begin();
  for (const Subscriber& s : subscribers_) {
    while (saved != snap.subscribers_.end() && saved->id < s.id) {
      take_saved(*saved++, report);
    }
    const bool also_saved = saved != snap.subscribers_.end() && saved->id == s.id;
    switch (s.kind) {
      case SubscriberKind::Rejuvenated:
        if (also_saved) {
          take_saved(*saved++, report);
        } else {
          ++report.rejuvenated_dropped;  // created after the checkpoint: its service's image predates it
        }
        break;
      case SubscriberKind::Driver:
        // Ids are never reused and the snapshot holds only Rejuvenated ids, so a Driver id is never saved.
        REJUV_ASSERT(!also_saved, "a driver subscription id appears in a snapshot");
        keep_driver(s, snap, report);
        break;
    }
  }
  while (saved != snap.subscribers_.end()) {
    take_saved(*saved++, report);
  }
  subscribers_.swap(scratch_);
  scratch_.clear();
  scratch_.reserve(subscribers_.capacity());
  return report;
}

void Broker::take_saved(const BrokerSnapshot::Subscription& saved, RestoreReport& report) {
  const std::uint32_t idx = *topic_index(saved.topic);
  const Subscriber* live = find(saved.id);
  if (live == nullptr) {
    ++report.rejuvenated_recreated;
  }
  scratch_.push_back(Subscriber{.id = saved.id,
                                .service = saved.service,
                                .topic = idx,
                                .kind = SubscriberKind::Rejuvenated,
                                .cursor = saved.cursor,
                                .stats = live != nullptr ? live->stats : SubscriberStats{}});
  ++report.rejuvenated_restored;
}

void Broker::keep_driver(const Subscriber& driver, const BrokerSnapshot& snap, RestoreReport& report) {
  const ObjectId object = topics_[driver.topic].object;
  if (std::any_of(snap.subscribers_.begin(), snap.subscribers_.end(),
                  [&](const auto& r) { return r.service == driver.service && r.topic == object; })) {
    ++report.drivers_dropped;
    return;
  }
  scratch_.push_back(driver);
  // Only what is published after the rollback: never the checkpoint's backlog again, never a generation
  // that the rollback erased (docs/design.md §7 rollback step 3).
  scratch_.back().cursor = topics_[driver.topic].head;
  ++report.drivers_rebased;
}

}  // namespace rejuv::broker
