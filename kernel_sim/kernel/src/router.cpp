// Routing (docs/design.md §5; docs/protocol.md "Delivery and flow control"): every publication is decoded through
// the capability system (Topic + Write in the current mode) and size-checked against its topic, written to
// the broker's ring, then pushed to each subscriber's channel in publish order. A full channel leaves the
// message in the ring (the subscriber's entry waits in its out-queue; the broker clamps and counts what
// it overruns): a service that stops reading never blocks the kernel or anyone else.
//
// Lockstep determinism: publications read during a step are staged and routed at the end of each round in
// canonical order (publisher id, then arrival), DDS samples sorted by (timestamp, reader), timers by (due,
// service, id): the interleaving every service sees does not depend on scheduling.
#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <numeric>

#include "impl.hpp"

namespace rejuv::kernel {

void Router::ingest_publish(ServiceRuntime& s, std::uint32_t slot, std::span<const std::byte> payload) {
  if (k.stopping) return;
  if (k.clock_mode == ClockMode::Realtime) {
    route_publish(s, slot, payload);
    return;
  }
  if (!s.flow_.admit_publication()) {
    if (s.stats.flood_dropped++ == 0)
      k.log("'%s' publishes more than %zu messages in one step; dropping the excess", s.name.c_str(),
            kMaxStagedPerStep);
    return;
  }
  k.lockstep.stage_publication(s.id, slot, payload);
}

void Router::flush_staged() {
  k.lockstep.drain_publications([&](std::uint32_t origin, std::uint32_t slot, std::span<const std::byte> payload) {
    ServiceRuntime& s = k.services[origin];
    if (s.proc.phase() == Phase::Dead) return;  // output of a service that died since: discarded
    route_publish(s, slot, payload);
  });
}

void Router::route_samples() {
  k.lockstep.drain_samples([&](const std::pair<std::uint64_t, std::uint32_t>& key, std::monostate,
                               std::span<const std::byte> bytes) {
    const std::uint32_t reader = key.second;
    if (const auto topic = k.bridge->readers()[reader].topic) publish_as_kernel(*topic, bytes, From::Bridge);
  });
}

void Router::route_publish(ServiceRuntime& s, std::uint32_t slot, std::span<const std::byte> payload) {
  auto inv = k.caps.decode(s.id, Slot(slot), cap::Operation::Publish);
  if (!inv) {
    drain_denials();  // counted, logged, published as a SecurityEvent (watch.cpp)
    return;
  }
  const ObjectInfo& o = k.objects[inv->object().value()];
  REJUV_ASSERT(o.type != nullptr, "decode checked that the cap names a topic");
  if (payload.size() != o.type->size) {
    ++s.stats.wrong_size;
    k.refuse(s, "publish on '" + o.name + "': " + std::to_string(payload.size()) +
                    " bytes, the topic's type needs " + std::to_string(o.type->size));
    return;
  }
  if (o.kernel == policy::KernelEndpoint::Publishes) {
    k.refuse(s,
             "publish on '" + o.name + "', which only the kernel publishes");  // the audit forbids the grant
    return;
  }
  k.rejuvenator.note_publication(s.id, o.id, payload);  // a discarded replay, counted (catch_up.hpp)
  if (k.rejuvenator.drops_publication(s.id, o.id))
    return;  // the chain catching up: its estimate is not the controllers' yet
  if (!within_budget(s, slot)) return;
  auto g = k.broker.publish(o.id, payload, k.now());
  if (!g) {
    k.refuse(s, "broker: " + std::string(broker::to_string(g.error())));
    return;
  }
  ++s.stats.publishes;
  ++s.published[o.id.value()];
  after_publish(o.id, payload, *g, s.id, From::Service);
}

// Over budget is not a violation and rolls nothing back (docs/sandbox.md "Floods cost only the flooder"): the
// rate of ext_link follows the ground station's datagrams, so an outsider could otherwise force rollbacks;
// the flood is cut here and its service's next rollback ends it.
bool Router::within_budget(ServiceRuntime& s, std::uint32_t slot) {
  if (budgets.size() <= s.id.value()) budgets.resize(k.services.size());
  std::optional<PublicationBudget>& b = budgets[s.id.value()];
  if (!b) {
    const std::uint32_t per_s =
        s.config.spec != nullptr
            ? launch::sandbox_limits(k.graph.graph, *s.config.spec).max_publications_per_s
            : launch::defaults::kSandboxPublicationsPerS;
    b = PublicationBudget{.rate = RateBudget(per_s, per_s)};  // a burst of one second's worth
  }
  const Nanos now = k.now();
  b->dropping = !b->rate.take(now);
  if (!b->dropping) return true;
  const std::uint64_t over = ++s.stats.publications_over_budget;
  if (now >= b->next_report) {
    b->next_report = now + kReportEvery;
    k.log("'%s' publishes over its budget of %llu/s: %llu publication(s) dropped (%llu in all)",
          s.name.c_str(), static_cast<unsigned long long>(b->rate.per_second()),
          static_cast<unsigned long long>(over - b->reported), static_cast<unsigned long long>(over));
    b->reported = over;
    publish_security_event(now, s.id, slot, rejuv_msg_SECURITY_PUBLICATION_BUDGET, k.caps.mode(),
                           static_cast<std::uint8_t>(cap::Operation::Publish));
  }
  return false;
}

bool Router::dropping(const ServiceRuntime& s) {
  if (s.id.value() >= budgets.size() || !budgets[s.id.value()]) return false;
  PublicationBudget& b = *budgets[s.id.value()];
  if (b.dropping && b.rate.refilled(k.now(), 1)) b.dropping = false;
  return b.dropping;
}

void Router::publish_as_kernel(ObjectId topic, std::span<const std::byte> payload, From from) {
  if (from == From::Bridge && k.rejuvenator.catch_up().logs(topic) &&
      k.rejuvenator.keep_plant_sample(topic, payload, dds::plant_topics::stamp_of(payload).value_or(0))) {
    return;  // behind the replay in progress, which hands it on in its turn
  }
  auto g = k.broker.publish(topic, payload, k.now());
  if (!g) {
    k.log("kernel publish on '%s' refused: %s", k.objects[topic.value()].name.c_str(),
          std::string(broker::to_string(g.error())).c_str());
    return;
  }
  after_publish(topic, payload, *g, std::nullopt, from);
}

void Router::add_subscriber(broker::SubscriberId id, SubscriberInfo info) {
  if (subscribers.size() <= id.value()) subscribers.resize(id.value() + 1);
  subscribers[id.value()] = info;
}

std::optional<std::uint64_t> Router::routed_to(broker::SubscriberId id) const {
  if (id.value() >= subscribers.size()) return std::nullopt;
  return subscribers[id.value()].routed;
}

void Router::publish_kernel_bytes(std::string_view type_name, std::span<const std::byte> message) {
  for (const ObjectInfo& o : k.objects) {
    if (o.type != nullptr && o.type->name == type_name && o.kernel == policy::KernelEndpoint::Publishes) {
      publish_as_kernel(o.id, message);
    }
  }
}

void Router::publish_sr_mode() {
  mode_announced = true;
  KernelMessage<rejuv_msg_SrMode> m;
  m.fields.timestamp_ns = static_cast<std::uint64_t>(k.now().count());
  m.fields.mode = static_cast<rejuv_msg_SrModeKind>(index_of(k.caps.mode()));
  m.fields.epoch = k.kernel_clock.epoch().value();
  m.fields.generation = 0;
  publish_kernel_message(m);
}

void Router::publish_security_event(Nanos at, ServiceId service, std::uint32_t slot, rejuv_msg_SecurityEventKind kind,
                                    SrMode mode, std::uint8_t operation, std::uint8_t error) {
  KernelMessage<rejuv_msg_SecurityEvent> m;
  m.fields.timestamp_ns = static_cast<std::uint64_t>(at.count());
  m.fields.service_id = service.value();
  m.fields.slot = slot;
  m.fields.operation = operation;
  m.fields.error = error;
  m.fields.mode = static_cast<rejuv_msg_SrModeKind>(index_of(mode));
  m.fields.kind = kind;
  publish_kernel_message(m);
}

bool Router::write_to_bridge(ObjectId topic, std::span<const std::byte> payload) {
  if (auto ok = k.bridge->write_out(topic, payload); !ok) {
    k.log("%s", ok.error().to_string().c_str());
    k.stop_run(StopReason::PlantExited, ok.error().to_string());
    return false;
  }
  return true;
}

void Router::after_publish(ObjectId topic, std::span<const std::byte> payload, broker::TopicGeneration g,
                           std::optional<ServiceId> publisher, From from) {
  if (from != From::Replay)
    watch_publication(k.objects[topic.value()], payload, g, publisher);  // observers (watch.cpp)
  if (k.bridge &&
      (from == From::Service || from == From::Kernel)) {  // what came in from the plant does not go back out
    if (k.rejuvenator.routing_frozen()) {  // a checkpoint or rollback is timed: written by resume_routing
      k.rejuvenator.hold_bridge_write(topic, payload);
    } else {
      (void)write_to_bridge(topic, payload);
    }
  }
  finish_routes(topic);
}

void Router::finish_routes(ObjectId topic) {
  auto routes = k.broker.subscribers_of(topic);
  if (!routes) return;
  for (const broker::Route& r : *routes) {
    ServiceRuntime& s = k.services[r.service.value()];
    if (r.subscriber.value() < subscribers.size()) {
      SubscriberInfo& info = subscribers[r.subscriber.value()];
      ++info.routed;
      if (info.polled) {  // stays in the ring until something else wakes the service (hand_over_polled)
        s.flow_.note_polled();
        continue;
      }
    }
    push_ring(s, r.subscriber);
  }
}

void Router::hand_over_polled(ServiceRuntime& s) {
  if (k.rejuvenator.routing_frozen() || !s.flow_.take_polled())
    return;  // taken first: push_ring below comes back here
  for (const SubscriptionRecord& r : s.subscriptions) {
    if (!subscribers[r.id.value()].polled) continue;
    for (std::size_t n = k.broker.pending(r.id).value_or(0); n > 0; --n) push_ring(s, r.id);
  }
}

// ---- output to a service ----

void Router::new_step() {
  for (ServiceRuntime& s : k.services) s.flow_.new_step();
}

void Router::set_writable_interest(ServiceRuntime& s, bool want) {
  if (!s.proc.channel.valid() || !s.flow_.set_want_writable(want)) return;
  (void)k.epoll.modify(s.proc.channel.fd(), token(Source::Channel, s.id.value()),
                       sys::Interest{.readable = !k.input.paused(s), .writable = want});
}

Router::SendResult Router::send_now(ServiceRuntime& s, std::span<const std::byte> frame) {
  if (!s.proc.channel.valid()) return SendResult::Failed;
  if (batch.is_open()) {
    if (batch.add(s.id, s.flow_, frame)) uncork_service(s);  // full
    return SendResult::Sent;
  }
  auto sent = s.proc.channel.send(frame);
  if (sent) {
    s.flow_.count_sent();
    return SendResult::Sent;
  }
  if (sent.error().error == EAGAIN) {
    s.flow_.hold(frame);
    set_writable_interest(s, true);
    return SendResult::Blocked;
  }
  return SendResult::Failed;  // EPIPE: the service is gone; its pidfd will say so
}

bool Router::deliver_one(ServiceRuntime& s, broker::SubscriberId subscriber) {
  const SubscriberInfo& info = subscribers[subscriber.value()];
  // Read is enforced in the current mode at every delivery, not only at the Subscribe: a subscriber whose mode
  // holds no Read on the topic now (a link between hosts in the secure interval) gets nothing, and what is
  // waiting for it is consumed unseen, so that none of it is handed over once the mode gives Read back.
  const auto held = k.caps.lookup(cap::CapRef{.space = s.id, .slot = info.slot});
  if (!held || !held->rights.has(Right::Read)) {
    for (;;) {
      const auto skipped = k.broker.next(subscriber);
      if (!skipped || !*skipped) return false;
    }
  }
  auto next = k.broker.next(subscriber);
  if (!next || !*next) return false;
  const broker::Delivery& d = **next;
  // A polled subscription skips what its service slept through by design (uORB::Subscription reads the
  // newest): the service sees the gap in the generations; only a push subscriber that fell behind counts.
  if (!info.polled) s.stats.lost += d.lost;
  const Slot slot = info.slot;
  if (!deliver_tx.build(wire::FrameKind::Deliver, slot.value(), 0, d.generation.value(), d.payload)) return false;
  ++s.stats.delivered;
  return send_now(s, deliver_tx.bytes()) == SendResult::Sent;
}

void Router::push_ring(ServiceRuntime& s, broker::SubscriberId subscriber) {
  if (s.proc.phase() != Phase::Booted && s.proc.phase() != Phase::Ready) return;
  if (k.rejuvenator.routing_frozen())
    return;  // a checkpoint or rollback is timed (rejuvenator.cpp): it stays in the ring, swept after
  hand_over_polled(s);         // the service is about to wake: its polled news goes first
  if (!s.flow_.drained()) {
    s.flow_.queue_ring(subscriber);  // keep publish order: behind what is already waiting
    return;
  }
  (void)deliver_one(s, subscriber);
}

void Router::send_control(ServiceRuntime& s, std::span<const std::byte> frame) {
  if (!s.live() || !s.proc.channel.valid()) return;
  hand_over_polled(s);  // the service is about to wake: its polled news goes first
  if (s.flow_.drained()) {
    (void)send_now(s, frame);
    return;
  }
  switch (s.flow_.queue_control(frame)) {
    case FlowControl::Queued::Yes: return;
    case FlowControl::Queued::PoolFull:
      k.supervisor.kill_hung(s, "does not read its channel (control queue full)");
      return;
    case FlowControl::Queued::QueueFull:
      k.supervisor.kill_hung(s, "does not read its channel (out-queue full)");
      return;
  }
}

// ---- output batching (lockstep rounds: output_batch.hpp) ----

void Router::cork() {
  batch.open(k.services.size());
}

void Router::uncork() {
  batch.close();
  for (ServiceRuntime& s : k.services) {
    if (batch.has_frames(s.id)) uncork_service(s);
  }
}

void Router::uncork_service(ServiceRuntime& s) {
  batch.flush(s.id, s.proc.channel, s.flow_, [&](std::span<const std::byte> refused) {
    // In order: the first is held, the rest wait behind it as control frames (each counted when it leaves).
    std::size_t offset = 0;
    s.flow_.hold(wire::next_frame(refused, offset));
    set_writable_interest(s, true);
    while (offset < refused.size()) send_control(s, wire::next_frame(refused, offset));
  });
}

void Router::drain(ServiceRuntime& s) {
  for (;;) {
    if (!s.proc.channel.valid()) return;
    if (s.flow_.has_held()) {
      auto sent = s.proc.channel.send(s.flow_.held());
      if (!sent) return;  // EAGAIN: still full (or gone)
      s.flow_.held_sent();
    }
    if (s.flow_.pop([&](broker::SubscriberId subscriber) { (void)deliver_one(s, subscriber); },
                   [&](std::span<const std::byte> frame) { (void)send_now(s, frame); })) {
      continue;
    }
    if (s.flow_.take_sweep()) {
      for (const SubscriptionRecord& r : s.subscriptions) {
        while (!s.flow_.has_held() && deliver_one(s, r.id)) {
        }
        if (s.flow_.has_held()) {
          s.flow_.request_sweep();  // blocked again: continue when it drains
          return;
        }
      }
      continue;
    }
    set_writable_interest(s, false);
    return;
  }
}

}  // namespace rejuv::kernel
