// Channel input (docs/protocol.md): every frame a service sends is untrusted. The kernel checks framing
// (wire::decode), the protocol phase, then the capability (CapSystem::decode) before anything changes;
// a refused frame is counted and logged (rate-limited) and never stalls or crashes the kernel.
#include <cerrno>
#include <csignal>
#include <cstring>
#include <limits>

#include "impl.hpp"

namespace rejuv::kernel {

void Kernel::Impl::read_channel(ServiceRuntime& s) {
  // A burst of datagrams per recvmmsg (channel::BatchReader); no new burst once kFramesPerWakeup frames were
  // read in this wakeup (a packed datagram holds many).
  std::array<sys::Received, sys::kMaxReceiveBatch> receipts{};
  channel::BatchReader reader(rx_batch, receipts);
  const std::uint64_t frames_before = s.stats.frames_in;
  const auto lose_channel = [&] {
    // The service closed fd 3, or is exiting (its pidfd tells which, soon). A live service without a
    // channel cannot be driven: check_deadlines loses it if it is still running after a grace period.
    (void)epoll.remove(s.channel.fd());
    s.channel.close();
    s.channel_closed_at = wall();
  };
  for (;;) {
    if (!s.live() || !s.channel.valid()) return;  // a frame before this one lost the service
    if (!reader.buffered() && s.stats.frames_in - frames_before >= kFramesPerWakeup) return;
    // One fd at most per datagram: TakenPages carries its pages; on any other frame an fd is refused.
    auto got = reader.next_datagram(s.channel, 1, sys::Wait::No);
    if (!got) {
      if (got.error().error != ECONNRESET) log("channel of '%s': %s", s.name.c_str(), got.error().to_string().c_str());
      lose_channel();
      return;
    }
    if (!*got) return;  // drained: no second system call to find the channel empty
    const std::span<const std::byte> datagram = (*got)->bytes;
    sys::Received& r = *(*got)->receipt;
    if (r.closed) {
      lose_channel();
      return;
    }
    if (!r.truncated && r.fds_truncated && checkpoint) {
      // A TakenPages whose pages fd the kernel could not install (out of fds: MSG_CTRUNC) is its answer all
      // the same: the checkpoint is abandoned now, instead of killing every service at the snapshot deadline.
      auto frame = wire::decode(datagram, wire::Direction::ToKernel);
      if (frame && frame->kind == wire::FrameKind::TakenPages && expecting_image(s, *frame)) {
        ++s.stats.frames_in;
        checkpoint->failure = "the written pages of '" + s.name + "' could not be received (is the kernel out of fds?)";
        continue;
      }
    }
    if (r.truncated || r.fds_truncated) {
      ++s.stats.frames_in;
      refuse(s, r.truncated ? "datagram longer than the maximum frame size" : "frame carried file descriptors (closed)");
      continue;
    }
    if (!r.fds.empty()) {  // a datagram with an fd is one TakenPages frame (docs/protocol.md "Framing")
      ++s.stats.frames_in;
      auto frame = wire::decode(datagram, wire::Direction::ToKernel);
      if (!frame || frame->kind != wire::FrameKind::TakenPages) {
        refuse(s, "frame carried file descriptors (closed)");
        continue;
      }
      on_taken_pages(s, *frame, std::move(r.fds.front()));  // images.cpp
      continue;
    }
    // One frame or several back to back (wire::next_frame). A frame that does not decode ends its
    // datagram: past it the framing cannot be trusted.
    receive_datagram(s, datagram);
  }
}

void Kernel::Impl::receive_datagram(ServiceRuntime& s, std::span<const std::byte> datagram) {
  std::size_t offset = 0;
  do {
    ++s.stats.frames_in;
    auto frame = wire::decode(wire::next_frame(datagram, offset), wire::Direction::ToKernel);
    if (!frame) {
      refuse(s, wire::to_string(frame.error()));
      break;
    }
    handle_frame(s, *frame);
  } while (offset < datagram.size() && s.live() && s.channel.valid());  // a frame may lose the service
}

void Kernel::Impl::handle_frame(ServiceRuntime& s, const wire::FrameView& f) {
  const bool running = s.phase == Phase::Booted || s.phase == Phase::Ready;
  switch (f.kind) {
    case wire::FrameKind::Hello:
      if (s.phase != Phase::Spawned) {
        refuse(s, "Hello after boot");
        return;
      }
      if (f.header.aux != wire::kProtocolVersion) {
        log("'%s' speaks protocol version %llu, the kernel %u", s.name.c_str(),
            static_cast<unsigned long long>(f.header.aux), static_cast<unsigned>(wire::kProtocolVersion));
      }
      send_boot(s);
      s.phase = Phase::Booted;
      return;
    case wire::FrameKind::Ready:
      if (s.phase != Phase::Booted) {
        refuse(s, "Ready outside boot");
        return;
      }
      s.phase = Phase::Ready;
      return;
    case wire::FrameKind::Publish:
      if (!running) {
        refuse(s, "Publish before boot");
        return;
      }
      ingest_publish(s, f.header.slot, f.payload);
      return;
    case wire::FrameKind::Subscribe:
      if (!running) {
        refuse(s, "Subscribe before boot");
        return;
      }
      handle_subscribe(s, f);
      return;
    case wire::FrameKind::Invoke:
      if (!running) {
        refuse(s, "Invoke before boot");
        return;
      }
      handle_invoke(s, f);
      return;
    case wire::FrameKind::TimerArm: {
      if (!running) {
        refuse(s, "TimerArm before boot");
        return;
      }
      const auto spec = wire::payload_as<wire::TimerSpec>(f);
      constexpr std::uint64_t kMaxNs = std::uint64_t{1} << 62U;
      if (spec.first_ns >= kMaxNs || spec.period_ns >= kMaxNs) {
        refuse(s, "TimerArm: time out of range");
        return;
      }
      if (auto ok = timers.arm(s.id, spec.id, Nanos{static_cast<std::int64_t>(spec.first_ns)},
                               Nanos{static_cast<std::int64_t>(spec.period_ns)});
          !ok) {
        refuse(s, std::string("TimerArm: ") + std::string(clock::to_string(ok.error())));
        return;
      }
      if (clock_mode == ClockMode::Realtime) arm_timerfd();
      return;
    }
    case wire::FrameKind::TimerCancel:
      if (!running) {
        refuse(s, "TimerCancel before boot");
        return;
      }
      // A one-shot timer that fired while the cancel was in flight is gone already: not an error.
      (void)timers.cancel(s.id, f.header.aux);
      return;
    case wire::FrameKind::Log: {
      const auto head = wire::payload_as<wire::LogHeader>(f);
      const auto text = f.payload.subspan(sizeof(wire::LogHeader));
      const auto level = head.level <= static_cast<std::uint8_t>(wire::LogLevel::Error)
                             ? static_cast<wire::LogLevel>(head.level)
                             : wire::LogLevel::Info;
      service_log(s, level, std::string_view(reinterpret_cast<const char*>(text.data()), text.size()));
      return;
    }
    case wire::FrameKind::Idle:
      s.idle_count = f.header.aux;
      return;
    case wire::FrameKind::Taken:
      on_taken(s, f);  // images.cpp
      return;
    case wire::FrameKind::TakenPages:
      refuse(s, "TakenPages without its pages (an fd)");  // with them it is read in read_channel
      return;
    case wire::FrameKind::Resumed:
    case wire::FrameKind::Copied:
      // Read by the image store itself (Resumed on a new channel, Copied on a resume socket; images.cpp);
      // on a service's channel it is a lie.
      refuse(s, std::string(wire::to_string(f.kind)) + " on a service channel");
      return;
    case wire::FrameKind::Boot:
    case wire::FrameKind::BootCap:
    case wire::FrameKind::BootParam:
    case wire::FrameKind::BootEnd:
    case wire::FrameKind::Deliver:
    case wire::FrameKind::Reply:
    case wire::FrameKind::TimerFired:
    case wire::FrameKind::Snapshot:
    case wire::FrameKind::Shutdown:
    case wire::FrameKind::Resume:
    case wire::FrameKind::NetDatagram:
    case wire::FrameKind::Fork:
    case wire::FrameKind::Patch:
      refuse(s, "kernel-to-service frame kind");  // decode(ToKernel) already refuses these
      return;
  }
}

void Kernel::Impl::reply(ServiceRuntime& s, std::uint32_t seq, std::int32_t error, std::uint64_t value,
                         std::span<const std::byte> data) {
  const wire::ReplyHeader head{.error = error, .reserved = 0, .value = value};
  if (tx.build_with(wire::FrameKind::Reply, 0, seq, 0, head, data)) send_control(s, tx.bytes());
}

// The reply codes and rights bits of the wire (rejuv/channel/codes.hpp), one definition for kernel and SDK.
using channel::denial_code;
using channel::rights_from_bits;

void Kernel::Impl::handle_subscribe(ServiceRuntime& s, const wire::FrameView& f) {
  if ((f.header.aux & ~wire::kSubscribePolled) != 0) {
    reply(s, f.header.seq, op_code(wire::OpError::BadArgument));
    return;
  }
  const bool polled = f.header.aux == wire::kSubscribePolled;
  auto inv = caps.decode(s.id, Slot(f.header.slot), cap::Operation::Subscribe);
  if (!inv) {
    reply(s, f.header.seq, denial_code(inv.error()));
    return;
  }
  const auto kind = s.rejuvenate ? broker::SubscriberKind::Rejuvenated : broker::SubscriberKind::Driver;
  auto sub = broker.subscribe(s.id, inv->object(), kind);
  if (!sub) {
    reply(s, f.header.seq,
          op_code(sub.error() == broker::BrokerError::AlreadySubscribed ? wire::OpError::AlreadySubscribed
                                                                        : wire::OpError::NoSuchTopic));
    return;
  }
  if (subscribers.size() <= sub->value()) subscribers.resize(sub->value() + 1);
  subscribers[sub->value()] = SubscriberInfo{.service = s.id, .slot = Slot(f.header.slot),
                                             .routed = broker.pending(*sub).value_or(0), .polled = polled};
  s.subscriptions.push_back(SubscriptionRecord{.slot = Slot(f.header.slot), .topic = inv->object(), .id = *sub});
  reply(s, f.header.seq, 0);
  // uORB: a new subscriber first gets the latest message already published, if any (a polled one with its
  // next wake-up; hand_over_polled finds nothing if there is none).
  if (polled) {
    s.polled_pending = true;
  } else {
    push_ring(s, *sub);
  }
}

void Kernel::Impl::handle_invoke(ServiceRuntime& s, const wire::FrameView& f) {
  const auto head = wire::payload_as<wire::InvokeHeader>(f);
  const auto data = f.payload.subspan(sizeof(wire::InvokeHeader));
  const std::uint32_t seq = f.header.seq;
  const Slot slot(f.header.slot);
  // Out-of-range operation values go to decode too: it refuses and counts them (invalid_operation).
  const auto op = static_cast<cap::Operation>(head.operation);
  if (!cap::operation_from_wire(head.operation)) {
    auto inv = caps.decode(s.id, slot, op);
    reply(s, seq, inv ? op_code(wire::OpError::BadArgument) : denial_code(inv.error()));
    return;
  }
  switch (op) {
    case cap::Operation::Publish:
    case cap::Operation::Subscribe:
      reply(s, seq, op_code(wire::OpError::BadArgument));  // they have their own frames
      return;
    case cap::Operation::Copy:
    case cap::Operation::Mint: {
      // arg0: destination — bit 63 set: transfer to service (low 32 bits), else own slot arg0.
      // arg1: rights mask (low 8 bits), Mint: badge (bits 8..63).
      cap::Destination to = (head.arg0 >> 63U) != 0
                                ? cap::Destination{cap::Transfer{.to = ServiceId(static_cast<std::uint32_t>(head.arg0))}}
                                : cap::Destination{cap::OwnSlot{.slot = Slot(static_cast<std::uint32_t>(head.arg0))}};
      if ((head.arg0 >> 63U) == 0 && head.arg0 > 0xFFFF'FFFFU) {
        reply(s, seq, op_code(wire::OpError::BadArgument));
        return;
      }
      const Rights mask = rights_from_bits(head.arg1 & 0xFFU);
      const cap::Args args = op == cap::Operation::Copy
                                 ? cap::Args{cap::CopyArgs{.to = to, .mask = mask}}
                                 : cap::Args{cap::MintArgs{.to = to, .mask = mask, .badge = cap::Badge(head.arg1 >> 8U)}};
      auto done = caps.decode_and_invoke(s.id, slot, op, args);
      if (!done) {
        reply(s, seq, denial_code(done.error()));
        return;
      }
      reply(s, seq, 0, done->placed ? done->placed->slot.value() : 0);
      return;
    }
    case cap::Operation::Revoke:
    case cap::Operation::Delete: {
      auto done = caps.decode_and_invoke(s.id, slot, op);
      if (!done) {
        reply(s, seq, denial_code(done.error()));
        return;
      }
      reply(s, seq, 0, done->deleted);
      return;
    }
    case cap::Operation::NetSend:
    case cap::Operation::NetReceive:
      net_invoke(s, seq, slot, op, head.arg0, head.arg1, data);  // the network gate (netgate.cpp)
      return;
    case cap::Operation::CheckpointCreate:
    case cap::Operation::CheckpointRollback:
    case cap::Operation::TimerArm:
    case cap::Operation::LimitsWrite:
    case cap::Operation::LimitsRead:
    case cap::Operation::PersistentRead:
    case cap::Operation::PersistentWrite:
    case cap::Operation::ModeRequest:
      break;
  }
  // Data-plane operations on non-topic objects: decode first (a denial leaves no trace), then invoke.
  auto inv = caps.decode(s.id, slot, op);
  if (!inv) {
    reply(s, seq, denial_code(inv.error()));
    return;
  }
  ObjectInfo& o = objects[inv->object().value()];
  switch (op) {
    case cap::Operation::CheckpointCreate:
      // DESIGN §7: answered when generation g is committed (images.cpp); in a restored image never.
      if (!sr) {
        reply(s, seq, op_code(wire::OpError::NotSupported));
      } else if (checkpoint_request || checkpoint) {
        reply(s, seq, op_code(wire::OpError::Refused));
      } else {
        checkpoint_request = std::pair(std::optional<ServiceId>(s.id), seq);
      }
      return;
    case cap::Operation::CheckpointRollback:
      if (!sr || images.size() == 0) {
        reply(s, seq, op_code(sr ? wire::OpError::Refused : wire::OpError::NotSupported));
        return;
      }
      reply(s, seq, 0);
      request_rollback("'" + s.name + "' requested a rollback");
      return;
    case cap::Operation::TimerArm:
      // The rejuvenation timer (§V-A do_timer): arg0 = delay [ns], arg1 = 1 for periodic.
      if (!sr || head.arg0 > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
        reply(s, seq, op_code(sr ? wire::OpError::BadArgument : wire::OpError::NotSupported));
        return;
      }
      arm_rejuvenation(s, seq, Nanos(static_cast<std::int64_t>(head.arg0)),
                       head.arg1 != 0 ? Nanos(static_cast<std::int64_t>(head.arg0)) : Nanos{0});
      return;
    case cap::Operation::LimitsWrite:
      if (data.size() > 4096) {
        reply(s, seq, op_code(wire::OpError::BadArgument));
        return;
      }
      o.limits.assign(data.begin(), data.end());
      sr_event(SrEventKind::LimitsWritten, {}, {}, s.id);
      reply(s, seq, 0, o.limits.size());
      return;
    case cap::Operation::LimitsRead:
      reply(s, seq, 0, o.limits.size(), o.limits);
      return;
    case cap::Operation::PersistentRead: {
      const std::uint64_t offset = head.arg0;
      const std::uint64_t length = head.arg1 == 0 ? o.persistent.size() : head.arg1;
      if (offset > o.persistent.size() || length > o.persistent.size() - offset) {
        reply(s, seq, op_code(wire::OpError::OutOfRange));
        return;
      }
      reply(s, seq, 0, length, std::span<const std::byte>(o.persistent).subspan(offset, length));
      return;
    }
    case cap::Operation::PersistentWrite: {
      const std::uint64_t offset = head.arg0;
      if (offset > o.persistent.size() || data.size() > o.persistent.size() - offset) {
        reply(s, seq, op_code(wire::OpError::OutOfRange));
        return;
      }
      std::memcpy(o.persistent.data() + offset, data.data(), data.size());
      reply(s, seq, 0, data.size());
      return;
    }
    case cap::Operation::ModeRequest: {
      if (head.arg0 >= kModeCount) {
        reply(s, seq, op_code(wire::OpError::BadArgument));
        return;
      }
      reply(s, seq, 0, head.arg0);
      set_mode(static_cast<SrMode>(head.arg0), s.id);  // images.cpp: caps, time page, sr_mode
      return;
    }
    case cap::Operation::Publish:
    case cap::Operation::Subscribe:
    case cap::Operation::Copy:
    case cap::Operation::Mint:
    case cap::Operation::Revoke:
    case cap::Operation::Delete:
    case cap::Operation::NetSend:
    case cap::Operation::NetReceive:
      break;  // handled above
  }
}

void Kernel::Impl::drain_denials() {
  const cap::AuditLog& audit = caps.audit_log();
  if (audit.pushed() == denials_drained) return;
  std::optional<ObjectId> events;
  for (const ObjectInfo& o : objects) {
    if (o.type != nullptr && o.type->name == msgs::TopicTraits<rejuv_msg_SecurityEvent>::name &&
        o.kernel == policy::KernelEndpoint::Publishes) {
      events = o.id;
    }
  }
  for (std::size_t i = audit.first_index_from(denials_drained); i < audit.size(); ++i) {
    const cap::Denial& d = audit[i];
    const bool known = d.service.value() < services.size();
    if (known) {
      ServiceRuntime& s = services[d.service.value()];
      ++s.stats.denials;
      if (s.limiter.allow(wall())) {
        log("denied: '%s' %s on slot %u: %s (mode %s)", s.name.c_str(), std::string(cap::to_string(d.operation)).c_str(),
            d.slot.value(), std::string(cap::to_string(d.error)).c_str(), std::string(to_string(d.mode)).c_str());
      } else {
        ++s.stats.log_suppressed;
      }
    }
    // DESIGN §3: every denial is also published as a SecurityEvent.
    if (events) {
      const rejuv_msg_SecurityEvent ev{.timestamp_ns = static_cast<std::uint64_t>(d.at.count()),
                                       .service_id = d.service.value(),
                                       .slot = d.slot.value(),
                                       .operation = static_cast<std::uint8_t>(d.operation),
                                       .error = static_cast<std::uint8_t>(d.error),
                                       .mode = static_cast<rejuv_msg_SrModeKind>(index_of(d.mode)),
                                       .kind = rejuv_msg_SECURITY_CAPABILITY_DENIAL};
      publish_as_kernel(*events, std::as_bytes(std::span(&ev, 1)));
    }
  }
  denials_drained = audit.pushed();
}

}  // namespace rejuv::kernel
