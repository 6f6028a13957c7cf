// ChannelInput (channel_input.hpp; docs/protocol.md): every frame a service sends is untrusted. The kernel
// checks framing (wire::decode), the protocol phase, then the capability (CapSystem::decode) before anything
// changes; a refused frame is counted and logged (rate-limited) and never stalls or crashes the kernel.
#include <cerrno>
#include <csignal>
#include <cstring>
#include <limits>
#include <variant>

#include "impl.hpp"
#include "invocation.hpp"
#include "rejuv/core/overloaded.hpp"

namespace rejuv::kernel {

void ChannelInput::read_channel(ServiceRuntime& s) {
  read_frames(s);
  if (k.clock_mode == ClockMode::Realtime && k.router.dropping(s)) pause(s);
}

void ChannelInput::pause(ServiceRuntime& s) {
  if (!s.live() || !s.proc.channel.valid() || paused(s)) return;
  if (paused_until.size() <= s.id.value()) paused_until.resize(k.services.size());
  paused_until[s.id.value()] = k.wall() + kBudgetPause;
  (void)k.epoll.modify(s.proc.channel.fd(), token(Source::Channel, s.id.value()),
                       sys::Interest{.readable = false, .writable = s.flow().want_writable()});
}

void ChannelInput::resume_paused(Nanos wall_now) {
  for (std::size_t i = 0; i < paused_until.size(); ++i) {
    if (!paused_until[i] || *paused_until[i] > wall_now) continue;
    paused_until[i].reset();
    ServiceRuntime& s = k.services[i];
    if (!s.proc.channel.valid()) continue;  // gone meanwhile; a restored incarnation's channel is read anyway
    (void)k.epoll.modify(s.proc.channel.fd(), token(Source::Channel, s.id.value()),
                         sys::Interest{.readable = true, .writable = s.flow().want_writable()});
  }
}

std::optional<Nanos> ChannelInput::next_resume() const {
  std::optional<Nanos> first;
  for (const std::optional<Nanos>& t : paused_until) {
    if (t && (!first || *t < *first)) first = t;
  }
  return first;
}

void ChannelInput::read_frames(ServiceRuntime& s) {
  // A burst of datagrams per recvmmsg (channel::BatchReader); no new burst once kFramesPerWakeup frames were
  // read in this wakeup (a packed datagram holds many).
  std::array<sys::Received, sys::kMaxReceiveBatch> receipts{};
  channel::BatchReader reader(rx_batch, receipts);
  const std::uint64_t frames_before = s.stats.frames_in;
  const auto lose_channel = [&] {
    // The service closed fd 3, or is exiting (its pidfd tells which, soon). A live service without a
    // channel cannot be driven: check_deadlines loses it if it is still running after a grace period.
    (void)k.epoll.remove(s.proc.channel.fd());
    s.proc.channel.close();
    s.proc.channel_closed_at = k.wall();
  };
  for (;;) {
    if (!s.live() || !s.proc.channel.valid()) return;  // a frame before this one lost the service
    if (!reader.buffered() && s.stats.frames_in - frames_before >= kFramesPerWakeup) return;
    // One fd at most per datagram: TakenPages carries its pages; on any other frame an fd is refused.
    auto got = reader.next_datagram(s.proc.channel, 1, sys::Wait::No);
    if (!got) {
      if (got.error().error != ECONNRESET)
        k.log("channel of '%s': %s", s.name.c_str(), got.error().to_string().c_str());
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
    if (!r.truncated && r.fds_truncated && k.rejuvenator.coordinator().running() != nullptr) {
      // A TakenPages whose pages fd the kernel could not install (out of fds: MSG_CTRUNC) is its answer all
      // the same: the checkpoint is abandoned now, instead of killing every service at the snapshot deadline.
      auto frame = wire::decode(datagram, wire::Direction::ToKernel);
      if (frame && frame->kind == wire::FrameKind::TakenPages && k.rejuvenator.expecting_image(s, *frame)) {
        ++s.stats.frames_in;
        k.rejuvenator.fail_checkpoint("the written pages of '" + s.name +
                                      "' could not be received (is the kernel out of fds?)");
        continue;
      }
    }
    if (r.truncated || r.fds_truncated) {
      ++s.stats.frames_in;
      k.refuse(s, r.truncated ? "datagram longer than the maximum frame size"
                              : "frame carried file descriptors (closed)");
      continue;
    }
    if (!r.fds.empty()) {  // a datagram with an fd is one TakenPages frame (docs/protocol.md "Framing")
      ++s.stats.frames_in;
      auto frame = wire::decode(datagram, wire::Direction::ToKernel);
      if (!frame || frame->kind != wire::FrameKind::TakenPages) {
        k.refuse(s, "frame carried file descriptors (closed)");
        continue;
      }
      k.rejuvenator.on_taken_pages(s, *frame, std::move(r.fds.front()));  // checkpoint.cpp
      continue;
    }
    // One frame or several back to back (wire::next_frame). A frame that does not decode ends its
    // datagram: past it the framing cannot be trusted.
    receive_datagram(s, datagram);
  }
}

void ChannelInput::receive_datagram(ServiceRuntime& s, std::span<const std::byte> datagram) {
  std::size_t offset = 0;
  do {
    ++s.stats.frames_in;
    auto frame = wire::decode(wire::next_frame(datagram, offset), wire::Direction::ToKernel);
    if (!frame) {
      k.refuse(s, wire::to_string(frame.error()));
      break;
    }
    handle_frame(s, *frame);
  } while (offset < datagram.size() && s.live() && s.proc.channel.valid());  // a frame may lose the service
}

namespace {
// The frames a service may send only once booted (docs/protocol.md "Boot"): refused before.
constexpr bool needs_boot(wire::FrameKind kind) {
  using K = wire::FrameKind;
  return kind == K::Publish || kind == K::Subscribe || kind == K::Invoke || kind == K::TimerArm ||
         kind == K::TimerCancel;
}
}  // namespace

void ChannelInput::handle_hello(ServiceRuntime& s, const wire::FrameView& f) {
  if (s.proc.phase() != Phase::Spawned) {
    k.refuse(s, "Hello after boot");
    return;
  }
  if (f.header.aux != wire::kProtocolVersion) {
    k.log("'%s' speaks protocol version %llu, the kernel %u", s.name.c_str(),
          static_cast<unsigned long long>(f.header.aux), static_cast<unsigned>(wire::kProtocolVersion));
  }
  k.supervisor.send_boot(s);
  s.proc.booted();
}

void ChannelInput::handle_ready(ServiceRuntime& s) {
  if (s.proc.phase() != Phase::Booted) {
    k.refuse(s, "Ready outside boot");
    return;
  }
  s.proc.became_ready();
  k.supervisor.apply_realtime(s);  // realtime.cpp: a (re)started service joins the real-time plan
}

void ChannelInput::handle_timer_arm(ServiceRuntime& s, const wire::FrameView& f) {
  const auto spec = wire::payload_as<wire::TimerSpec>(f);
  constexpr std::uint64_t kMaxNs = std::uint64_t{1} << 62U;
  if (spec.first_ns >= kMaxNs || spec.period_ns >= kMaxNs) {
    k.refuse(s, "TimerArm: time out of range");
    return;
  }
  if (auto ok = k.timers.arm(s.id, spec.id, Nanos{static_cast<std::int64_t>(spec.first_ns)},
                             Nanos{static_cast<std::int64_t>(spec.period_ns)});
      !ok) {
    k.refuse(s, std::string("TimerArm: ") + std::string(clock::to_string(ok.error())));
    return;
  }
  if (k.clock_mode == ClockMode::Realtime) k.arm_timerfd();
}

void ChannelInput::handle_log(ServiceRuntime& s, const wire::FrameView& f) {
  const auto head = wire::payload_as<wire::LogHeader>(f);
  const auto text = f.payload.subspan(sizeof(wire::LogHeader));
  const auto level = head.level <= static_cast<std::uint8_t>(wire::LogLevel::Error)
                         ? static_cast<wire::LogLevel>(head.level)
                         : wire::LogLevel::Info;
  k.service_log(s, level, std::string_view(reinterpret_cast<const char*>(text.data()), text.size()));
}

void ChannelInput::handle_frame(ServiceRuntime& s, const wire::FrameView& f) {
  if (needs_boot(f.kind) && s.proc.phase() != Phase::Booted && s.proc.phase() != Phase::Ready) {
    k.refuse(s, std::string(wire::to_string(f.kind)) + " before boot");
    return;
  }
  switch (f.kind) {
    case wire::FrameKind::Hello:
      handle_hello(s, f);
      return;
    case wire::FrameKind::Ready:
      handle_ready(s);
      return;
    case wire::FrameKind::Publish: k.router.ingest_publish(s, f.header.slot, f.payload); return;
    case wire::FrameKind::Subscribe:
      handle_subscribe(s, f);
      return;
    case wire::FrameKind::Invoke:
      handle_invoke(s, f);
      return;
    case wire::FrameKind::TimerArm:
      handle_timer_arm(s, f);
      return;
    case wire::FrameKind::TimerCancel:
      // A one-shot timer that fired while the cancel was in flight is gone already: not an error.
      (void)k.timers.cancel(s.id, f.header.aux);
      return;
    case wire::FrameKind::Log:
      handle_log(s, f);
      return;
    case wire::FrameKind::Idle:
      k.router.on_idle(s, f.header.aux);
      return;
    case wire::FrameKind::Taken:
      k.rejuvenator.on_taken(s, f);  // checkpoint.cpp
      return;
    case wire::FrameKind::TakenPages:
      k.refuse(s, "TakenPages without its pages (an fd)");  // with them it is read in read_channel
      return;
    case wire::FrameKind::Resumed:
    case wire::FrameKind::Copied:
      // Read by the image store itself (Resumed on a new channel, rollback.cpp; Copied on a resume socket,
      // kernel_sim/image);
      // on a service's channel it is a lie.
      k.refuse(s, std::string(wire::to_string(f.kind)) + " on a service channel");
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
    case wire::FrameKind::Committed:
    case wire::FrameKind::Sync:
      k.refuse(s, "kernel-to-service frame kind");  // decode(ToKernel) already refuses these
      return;
  }
}

void ChannelInput::reply(ServiceRuntime& s, std::uint32_t seq, std::int32_t error, std::uint64_t value,
                         std::span<const std::byte> data) {
  const wire::ReplyHeader head{.error = error, .reserved = 0, .value = value};
  if (k.tx.build_with(wire::FrameKind::Reply, 0, seq, 0, head, data)) k.router.send_control(s, k.tx.bytes());
}

// The reply codes and rights bits of the wire (rejuv/channel/codes.hpp), one definition for kernel and SDK.
using channel::denial_code;
using channel::rights_from_bits;

void ChannelInput::handle_subscribe(ServiceRuntime& s, const wire::FrameView& f) {
  if ((f.header.aux & ~wire::kSubscribePolled) != 0) {
    reply(s, f.header.seq, op_code(wire::OpError::BadArgument));
    return;
  }
  const bool polled = f.header.aux == wire::kSubscribePolled;
  auto inv = k.caps.decode(s.id, Slot(f.header.slot), cap::Operation::Subscribe);
  if (!inv) {
    reply(s, f.header.seq, denial_code(inv.error()));
    return;
  }
  const auto kind = s.config.rejuvenate ? broker::SubscriberKind::Rejuvenated : broker::SubscriberKind::Driver;
  auto sub = k.broker.subscribe(s.id, inv->object(), kind);
  if (!sub) {
    reply(s, f.header.seq,
          op_code(sub.error() == broker::BrokerError::AlreadySubscribed ? wire::OpError::AlreadySubscribed
                                                                        : wire::OpError::NoSuchTopic));
    return;
  }
  k.router.add_subscriber(*sub, Router::SubscriberInfo{.service = s.id,
                                                       .slot = Slot(f.header.slot),
                                                       .routed = k.broker.pending(*sub).value_or(0),
                                                       .polled = polled});
  s.subscriptions.push_back(SubscriptionRecord{.slot = Slot(f.header.slot), .topic = inv->object(), .id = *sub});
  reply(s, f.header.seq, 0);
  // uORB: a new subscriber first gets the latest message already published, if any (a polled one with its
  // next wake-up; hand_over_polled finds nothing if there is none).
  if (polled) {
    k.router.note_polled(s);
  } else {
    k.router.push_ring(s, *sub);
  }
}

// ---- Invoke: decoded per object kind (invocation.hpp), then invoked on the part that owns the kind ----

Result<ObjectInvocation, BadInvoke> decode_invocation(cap::Operation op, const wire::InvokeHeader& head,
                                                      std::span<const std::byte> data) {
  using C = CheckpointInvocation;
  using N = NetInvocation;
  using L = LimitsInvocation;
  using P = PersistentInvocation;
  const auto bad = [](bool before_authority) {
    return std::unexpected(BadInvoke{.error = wire::OpError::BadArgument, .before_authority = before_authority});
  };
  const cap::Requirement need = cap::requirement(op);
  if (need.any_kind) {  // capability management (seL4 CNode)
    if (op == cap::Operation::Revoke || op == cap::Operation::Delete) {
      return CapInvocation{.op = op, .args = cap::NoArgs{}};
    }
    // arg0: destination — bit 63 set: transfer to service (low 32 bits), else own slot arg0.
    // arg1: rights mask (low 8 bits), Mint: badge (bits 8..63).
    const bool transfer = (head.arg0 >> 63U) != 0;
    if (!transfer && head.arg0 > 0xFFFF'FFFFU) return bad(true);
    const auto low = static_cast<std::uint32_t>(head.arg0);
    const cap::Destination to = transfer ? cap::Destination{cap::Transfer{.to = ServiceId(low)}}
                                         : cap::Destination{cap::OwnSlot{.slot = Slot(low)}};
    const Rights mask = rights_from_bits(head.arg1 & 0xFFU);
    if (op == cap::Operation::Copy) return CapInvocation{.op = op, .args = cap::CopyArgs{.to = to, .mask = mask}};
    return CapInvocation{.op = op, .args = cap::MintArgs{.to = to, .mask = mask, .badge = cap::Badge(head.arg1 >> 8U)}};
  }
  switch (need.kind) {
    case ObjectKind::Topic:
      return bad(true);  // Publish and Subscribe have their own frames
    case ObjectKind::Checkpoint:
      if (op == cap::Operation::CheckpointCreate) return CheckpointInvocation{.what = C::Create{}};
      if (op == cap::Operation::CheckpointRollback) return CheckpointInvocation{.what = C::Rollback{}};
      if (head.arg0 > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return bad(false);
      return CheckpointInvocation{
          .what = C::ArmTimer{.delay = Nanos(static_cast<std::int64_t>(head.arg0)), .periodic = head.arg1 != 0}};
    case ObjectKind::Network:
      if (op == cap::Operation::NetSend) {
        if (data.empty() || data.size() > wire::kMaxDatagramBytes) return bad(false);
        return NetInvocation{.what = N::Send{.datagram = data}};
      }
      if (head.arg0 == 0 || head.arg1 >= kNetVerdictCodes) return bad(false);
      return NetInvocation{.what = N::Verdict{.datagram = head.arg0, .reason = head.arg1}};
    case ObjectKind::Limits:
      if (op == cap::Operation::LimitsRead) return LimitsInvocation{.what = L::Read{}};
      if (data.size() > kMaxLimitsBytes) return bad(false);
      return LimitsInvocation{.what = L::Write{.data = data}};
    case ObjectKind::Persistent:
      if (op == cap::Operation::PersistentRead) {
        return PersistentInvocation{.what = P::Read{.offset = head.arg0, .length = head.arg1}};
      }
      return PersistentInvocation{.what = P::Write{.offset = head.arg0, .data = data}};
    case ObjectKind::Mode:
      if (head.arg0 >= kModeCount) return bad(false);
      return ModeInvocation{.mode = static_cast<SrMode>(head.arg0)};
  }
  return bad(true);  // unreachable: every kind is handled above
}

bool ChannelInput::provides(ObjectKind kind) const {
  return kind != ObjectKind::Checkpoint || k.sr;
}

void ChannelInput::refuse_invoke(ServiceRuntime& s, std::uint32_t seq, cap::Operation op, std::int32_t code) {
  if (op == cap::Operation::NetSend) k.net.count_send_refused();  // the gate counts every NetSend it refuses
  reply(s, seq, code);
}

void ChannelInput::handle_invoke(ServiceRuntime& s, const wire::FrameView& f) {
  const auto head = wire::payload_as<wire::InvokeHeader>(f);
  const auto data = f.payload.subspan(sizeof(wire::InvokeHeader));
  const std::uint32_t seq = f.header.seq;
  const Slot slot(f.header.slot);
  const auto op = cap::operation_from_wire(head.operation);
  if (!op) {
    // Out-of-range operation values go to the cap system too: it refuses and counts them (invalid_operation).
    auto inv = k.caps.decode(s.id, slot, static_cast<cap::Operation>(head.operation));
    reply(s, seq, inv ? op_code(wire::OpError::BadArgument) : denial_code(inv.error()));
    return;
  }
  auto decoded = decode_invocation(*op, head, data);
  if (!decoded && decoded.error().before_authority) {
    reply(s, seq, op_code(decoded.error().error));
    return;
  }
  if (decoded && std::holds_alternative<CapInvocation>(*decoded)) {
    // The cap system checks the authority with the arguments and carries the operation out (a denial leaves
    // no trace but the audit).
    auto done = k.caps.decode_and_invoke(s.id, slot, *op, std::get<CapInvocation>(*decoded).args);
    if (!done) {
      reply(s, seq, denial_code(done.error()));
      return;
    }
    reply(s, seq, 0, done->placed ? done->placed->slot.value() : done->deleted);
    return;
  }
  // The authority first (a denial answers before the arguments and leaves no trace but the audit), then
  // whether this kernel provides the kind, then the arguments.
  auto authority = k.caps.decode(s.id, slot, *op);
  if (!authority) {
    refuse_invoke(s, seq, *op, denial_code(authority.error()));
    return;
  }
  if (!provides(authority->kind())) {
    refuse_invoke(s, seq, *op, op_code(wire::OpError::NotSupported));
    return;
  }
  if (!decoded) {
    refuse_invoke(s, seq, *op, op_code(decoded.error().error));
    return;
  }
  ObjectInfo& o = k.objects[authority->object().value()];
  std::visit(Overloaded{
                 [&](const CapInvocation&) {},  // carried out above
                 [&](const CheckpointInvocation& c) { invoke_checkpoint(s, seq, c); },
                 [&](const NetInvocation& n) { k.net_invoke(s, seq, *authority, n); },  // netgate.cpp
                 [&](const LimitsInvocation& l) { invoke_limits(s, seq, o, l); },
                 [&](const PersistentInvocation& p) { invoke_persistent(s, seq, o, p); },
                 [&](const ModeInvocation& m) {
                   reply(s, seq, 0, index_of(m.mode));
                   k.rejuvenator.set_mode(m.mode, s.id);  // rejuvenator.cpp: caps, time page, sr_mode
                 },
             },
             *decoded);
}

void ChannelInput::invoke_checkpoint(ServiceRuntime& s, std::uint32_t seq, const CheckpointInvocation& c) {
  std::visit(Overloaded{
                 [&](const CheckpointInvocation::Create&) {
                   // docs/design.md §7: answered when generation g is committed (checkpoint.cpp); in a restored image never.
                   if (!k.rejuvenator.request_checkpoint(s.id, seq))
                     reply(s, seq, op_code(wire::OpError::Refused));
                 },
                 [&](const CheckpointInvocation::Rollback&) {
                   if (k.rejuvenator.images().size() == 0) {
                     reply(s, seq, op_code(wire::OpError::Refused));
                     return;
                   }
                   reply(s, seq, 0);
                   k.rejuvenator.request_rollback("'" + s.name + "' requested a rollback");
                 },
                 [&](const CheckpointInvocation::ArmTimer& t) {  // §V-A do_timer
                   k.rejuvenator.arm_rejuvenation(s, seq, t.delay, t.periodic ? t.delay : Nanos{0});
                 },
             },
             c.what);
}

void ChannelInput::invoke_limits(ServiceRuntime& s, std::uint32_t seq, ObjectInfo& o,
                                 const LimitsInvocation& l) {
  if (const auto* w = std::get_if<LimitsInvocation::Write>(&l.what)) {
    o.limits.assign(w->data.begin(), w->data.end());
    k.rejuvenator.sr_event(SrEventKind::LimitsWritten, {}, {}, s.id);
  }
  reply(s, seq, 0, o.limits.size(), std::holds_alternative<LimitsInvocation::Read>(l.what)
                                        ? std::span<const std::byte>(o.limits)
                                        : std::span<const std::byte>{});
}

void ChannelInput::invoke_persistent(ServiceRuntime& s, std::uint32_t seq, ObjectInfo& o,
                                     const PersistentInvocation& p) {
  const std::span<std::byte> cell(o.persistent);
  std::visit(Overloaded{
                 [&](const PersistentInvocation::Read& r) {
                   const std::uint64_t length = r.length == 0 ? cell.size() : r.length;
                   if (r.offset > cell.size() || length > cell.size() - r.offset) {
                     reply(s, seq, op_code(wire::OpError::OutOfRange));
                     return;
                   }
                   reply(s, seq, 0, length, cell.subspan(r.offset, length));
                 },
                 [&](const PersistentInvocation::Write& w) {
                   if (w.offset > cell.size() || w.data.size() > cell.size() - w.offset) {
                     reply(s, seq, op_code(wire::OpError::OutOfRange));
                     return;
                   }
                   std::memcpy(cell.data() + w.offset, w.data.data(), w.data.size());
                   reply(s, seq, 0, w.data.size());
                 },
             },
             p.what);
}

}  // namespace rejuv::kernel
