// The network gate (docs/design.md §2, §3; docs/protocol.md "Network gate"): the kernel owns the external link's UDP
// socket. A datagram is relayed to the service whose policy slot holds the NETWORK object with Read in the
// current mode (ext_link, in MC only) as one NetDatagram frame; otherwise it is dropped and counted — in
// RB/SC/UPDATE/CP no service holds Network (the secure execution interval, §III), so nothing from the
// network reaches the vehicle then. The kernel never interprets the bytes: it checks the size and the cap.
// NetSend goes out to the ground station after the cap check, so a send outside MC is a denial like any
// other. The ground station is the source of the last datagram the receiver judged valid (NetReceive with
// its verdict): the kernel does not interpret the bytes, ext_link does, and garbage must not steer telemetry.
// With a signing key in the launch file the gate checks one thing more, before relaying: that the datagram is
// a MAVLink 2 frame signed with the key, its timestamp no more than a minute behind the wall clock and after
// the last of its stream (kernel_sim/mavlink SignatureChecker: the envelope and the signature only, never the
// payload). A compromised ext_link then cannot act on an unsigned, a recorded or a replayed command: it never
// receives one; and since only a relayed datagram can be judged valid, none of them moves the telemetry.
#include <algorithm>
#include <cerrno>
#include <string>

#include "impl.hpp"

namespace rejuv::kernel {

namespace {
KernelError config_error(std::string message) {
  return KernelError{.kind = KernelError::Kind::Config, .message = std::move(message), .findings = {}};
}
}  // namespace

GroundLink::GroundLink(std::optional<mavlink::SigningKey> key, std::optional<sys::UdpAddress> ground)
    : ground_(std::move(ground)) {
  if (key) signing_.emplace(*key);
}

std::optional<mavlink::Frame> GroundLink::sign_outgoing(std::span<const std::byte> datagram, mavlink::SigningTime local_clock) {
  if (!signing_) return std::nullopt;
  // Strictly increasing on the vehicle's stream (spec "Timestamp Handling"), whatever the wall clock does.
  const mavlink::SigningTime stamp = std::max(local_clock, last_signed_ + mavlink::SigningClock::duration{1});
  auto signed_frame = mavlink::sign_frame(datagram, mavlink::Signer{.key = signing_->key(), .link_id = 0, .timestamp = stamp});
  if (signed_frame) last_signed_ = stamp;
  return signed_frame;
}

Result<void, mavlink::SigningRefusal> GroundLink::admit(std::span<const std::byte> datagram,
                                                        mavlink::SigningTime local_clock) {
  if (!signing_) return {};
  return signing_->check(datagram, local_clock);
}

void GroundLink::relayed(const sys::UdpAddress& from) {
  recent_[next_id_ % kRecentDatagrams] = Relayed{.id = next_id_, .from = from, .judged = false};
  ++next_id_;
}

Result<void, GroundLink::JudgeError> GroundLink::judge(std::uint64_t id, Verdict verdict) {
  Relayed& d = recent_[id % kRecentDatagrams];
  if (d.id != id || d.judged || id == 0) return fail(JudgeError::NotRelayed);
  d.judged = true;
  switch (verdict) {
    case Verdict::Valid: ground_ = d.from; break;
    case Verdict::Refused: break;
  }
  return {};
}

void NetGate::open(sys::UdpSocket socket, ObjectId object, std::uint16_t port, std::vector<Reader> readers,
                   GroundLink link) {
  REJUV_ASSERT(!is_open(), "the network gate is opened once");
  socket_ = std::move(socket);
  object_ = object;
  port_ = port;
  readers_ = std::move(readers);
  link_ = std::move(link);
  stats_.signing = link_.signing();
}

sys::SysResult<sys::UdpReceived> NetGate::receive() {
  auto r = socket_.receive(rx_);
  if (r) ++stats_.received;
  return r;
}

void NetGate::count_dropped(Drop why) {
  switch (why) {
    case Drop::Empty: ++stats_.dropped_empty; break;
    case Drop::Oversize: ++stats_.dropped_oversize; break;
    case Drop::SecureInterval: ++stats_.dropped_secure_interval; break;
    case Drop::NoReceiver: ++stats_.dropped_no_receiver; break;
    case Drop::Busy: ++stats_.dropped_busy; break;
  }
}

Result<void, mavlink::SigningRefusal> NetGate::admit(std::span<const std::byte> datagram,
                                                     mavlink::SigningTime local_clock) {
  auto admitted = link_.admit(datagram, local_clock);
  if (!admitted) {
    ++stats_.signing_refused;
    ++stats_.signing_refused_by_reason[static_cast<std::size_t>(admitted.error())];
  }
  return admitted;
}

void NetGate::relayed(const sys::UdpAddress& from) {
  ++stats_.relayed;
  link_.relayed(from);
}

Result<void, GroundLink::JudgeError> NetGate::judge(std::uint64_t id, std::uint64_t reason) {
  auto judged = link_.judge(id, reason == 0 ? GroundLink::Verdict::Valid : GroundLink::Verdict::Refused);
  if (!judged) return judged;
  if (reason == 0) {
    ++stats_.judged_valid;
  } else {
    ++stats_.judged_refused;
    ++stats_.refused_by_reason[reason];
  }
  return {};
}

sys::SysResult<void> NetGate::send(std::span<const std::byte> datagram, const sys::UdpAddress& to) {
  auto sent = socket_.send_to(datagram, to);
  if (sent) ++stats_.sent;
  return sent;
}

bool NetGate::may_log(Nanos wall_now) {
  log_tokens_ = std::min(10.0, log_tokens_ + to_seconds(wall_now - log_last_).count());
  log_last_ = wall_now;
  if (log_tokens_ >= 1) {
    log_tokens_ -= 1;
    return true;
  }
  ++log_suppressed_;
  return false;
}

Result<void, KernelError> Kernel::Impl::net_open() {
  const proto::NetworkSpec& spec = graph.graph.network();
  const std::string where = graph.path.string() + ": network";
  if (spec.disabled()) {
    log("network gate: disabled by the launch graph");
    return {};
  }
  // The NETWORK object the gate serves: named, or the policy's only one (none: no gate, nothing to serve).
  std::optional<ObjectId> object;
  if (!spec.object().empty()) {
    const auto found = policy.find_object(spec.object());
    if (!found || objects[found->value()].kind != ObjectKind::Network) {
      return fail(config_error(where + ".object: '" + spec.object() + "' is not a NETWORK object of the policy"));
    }
    object = *found;
  } else {
    for (const ObjectInfo& o : objects) {
      if (o.kind != ObjectKind::Network) continue;
      if (object) {
        return fail(config_error(where + ".object: the policy has several NETWORK objects; name the one the gate serves"));
      }
      object = o.id;
    }
    if (!object) return {};
  }
  if (spec.has_bind_port() && spec.bind_port() > 0xFFFFU) {
    return fail(config_error(where + ".bind_port: " + std::to_string(spec.bind_port()) + " is not a UDP port (0..65535)"));
  }
  const std::uint16_t port = options.network_port.value_or(
      spec.has_bind_port() ? static_cast<std::uint16_t>(spec.bind_port()) : kDefaultNetworkPort);
  auto address = sys::UdpAddress::parse(spec.bind_address().empty() ? "127.0.0.1" : spec.bind_address(), port);
  if (!address) return fail(config_error(where + ".bind_address: " + address.error()));

  // Who may ever receive: the policy slots of the object with Read in some mode.
  std::vector<NetGate::Reader> readers;
  std::string names;
  for (const ServiceRuntime& s : services) {
    for (const cap::BootCap& c : s.config.boot.caps) {
      if (c.object != *object) continue;
      if (std::none_of(c.rights.begin(), c.rights.end(), [](Rights r) { return r.has(Right::Read); })) continue;
      readers.push_back(NetGate::Reader{.service = s.id, .slot = c.slot});
      names += (names.empty() ? "'" : ", '") + s.name + "'";
    }
  }
  auto key = launch::signing_key(spec, graph.path);
  if (!key) return fail(config_error(where + "." + key.error().field + ": " + key.error().message));
  auto socket = sys::UdpSocket::bind(*address, sys::Blocking::No);
  if (!socket) {
    // An explicit port (a tool or a test asked for it) must be had; the graph's default port may be taken by
    // another run on this host: then this run flies without a ground link rather than not at all.
    const std::string why = "network gate: cannot bind " + address->to_string() + ": " + socket.error().to_string();
    if (options.network_port) return fail(KernelError{.kind = KernelError::Kind::System, .message = why, .findings = {}});
    log("%s; the external link is off for this run", why.c_str());
    return {};
  }
  auto bound = socket->local_address();
  if (!bound) return fail(KernelError{.kind = KernelError::Kind::System, .message = bound.error().to_string(), .findings = {}});
  // A ground station to send to before any has spoken (validated: launch::ground_address); the source of
  // the first valid message replaces it.
  std::optional<sys::UdpAddress> ground;
  if (const auto given = launch::ground_address(spec.ground_address())) {
    auto to = sys::UdpAddress::parse(given->ip, given->port);
    if (!to) return fail(config_error(where + ".ground_address: " + to.error()));
    ground = *to;
  }
  net.open(std::move(*socket), *object, bound->port, std::move(readers), GroundLink(*key, ground));
  if (clock_mode == ClockMode::Realtime) {
    if (auto ok = epoll.add(net.fd(), token(Source::Net, 0)); !ok) {
      return fail(KernelError{.kind = KernelError::Kind::System, .message = ok.error().to_string(), .findings = {}});
    }
  }
  log("network gate: udp %s for '%s' (%s)%s%s", bound->to_string().c_str(), objects[object->value()].name.c_str(),
      names.empty() ? "no service may receive" : names.c_str(), net.signing() ? ", MAVLink 2 signing required" : "",
      net.ground() ? (", sending to " + net.ground()->to_string() + " until a ground station speaks").c_str() : "");
  return {};
}

void Kernel::Impl::net_poll() {
  if (!net.is_open()) return;
  for (std::size_t i = 0; i < kDatagramsPerPoll; ++i) {
    auto r = net.receive();
    if (!r) {
      if (r.error().error != EAGAIN && net.may_log(wall())) log("network gate: %s", r.error().to_string().c_str());
      return;
    }
    if (r->datagram_size == 0) {
      net.count_dropped(NetGate::Drop::Empty);
      continue;
    }
    if (r->truncated || r->datagram_size > wire::kMaxDatagramBytes) {
      net.count_dropped(NetGate::Drop::Oversize);
      if (net.may_log(wall())) {
        log("network gate: dropped a %zu-byte datagram from %s (more than %zu bytes)", r->datagram_size,
            r->from.to_string().c_str(), wire::kMaxDatagramBytes);
      }
      continue;
    }
    // Decode through the cap system: which policy slot holds the object with Read in the current mode. A
    // lookup, not a service's request, so nothing is counted as a denial.
    const std::span<const std::byte> bytes = net.bytes_of(*r);
    // Whether a reader holds the network now (Read in the current mode).
    const auto holds = [&](const NetGate::Reader& reader) {
      const auto c = caps.lookup(cap::CapRef{.space = reader.service, .slot = reader.slot});
      return c && c->kind == ObjectKind::Network && net.serves(c->object) && c->rights.has(Right::Read);
    };
    // Signing: checked only for a datagram that could be relayed now (in the SEI everything is dropped
    // unread, so a frame retransmitted there costs the stream nothing), before any service sees it, against
    // the wall clock (CLOCK_REALTIME) in every clock mode: the ground station stamps from its own.
    if (net.signing() && std::any_of(net.readers().begin(), net.readers().end(), holds)) {
      if (auto signed_ok = net.admit(bytes, mavlink::SigningClock::now()); !signed_ok) {
        if (net.may_log(wall())) {
          log("network gate: refused a %zu-byte datagram from %s: %s", r->size, r->from.to_string().c_str(),
              std::string(mavlink::to_string(signed_ok.error())).c_str());
        }
        continue;
      }
    }
    bool held = false;
    bool running = false;
    bool sent = false;
    const std::uint64_t id = net.next_id();
    for (const NetGate::Reader& reader : net.readers()) {
      if (!holds(reader)) continue;
      held = true;
      ServiceRuntime& s = services[reader.service.value()];
      if (s.proc.phase() != Phase::Ready || !s.proc.channel.valid() || stopping) continue;
      running = true;
      // A service that does not read its channel gets no more: queued frames are bounded, and overflowing
      // them would be its fault (docs/protocol.md "flow control") — a flood must not make it one.
      if (!s.flow().drained()) continue;
      if (!tx.build(wire::FrameKind::NetDatagram, reader.slot.value(), 0, id, bytes)) continue;
      router.send_control(s, tx.bytes());
      sent = true;
    }
    if (!held) {
      net.count_dropped(NetGate::Drop::SecureInterval);
      if (net.may_log(wall())) {
        log("network gate: dropped a %zu-byte datagram from %s: no service holds the network in mode %s", r->size,
            r->from.to_string().c_str(), std::string(to_string(caps.mode())).c_str());
      }
    } else if (!running) {
      net.count_dropped(NetGate::Drop::NoReceiver);
    } else if (!sent) {
      net.count_dropped(NetGate::Drop::Busy);
    } else {
      // Its source becomes the ground station only once the receiver judges it valid (net_invoke).
      net.relayed(r->from);
    }
  }
}

void Kernel::Impl::net_invoke(ServiceRuntime& s, std::uint32_t seq, const cap::Invocation& authority,
                              const NetInvocation& what) {
  if (const auto* verdict = std::get_if<NetInvocation::Verdict>(&what.what)) {
    // NetReceive: delivery is pushed (NetDatagram frames); what the receiver sends back is its verdict on
    // one of them: its id and 0 valid, else its refusal reason (a known code: decode_invocation). Checked
    // before anything changes: a datagram relayed to this gate lately, not judged yet.
    if (!net.judge(verdict->datagram, verdict->reason)) {
      input.reply(s, seq, static_cast<std::int32_t>(wire::OpError::BadArgument));
      return;
    }
    input.reply(s, seq, 0);
    return;
  }
  const std::span<const std::byte> data = std::get<NetInvocation::Send>(what.what).datagram;  // 1 … kMaxDatagramBytes
  // The gate is off (disabled, bind failed, another NETWORK object).
  if (!net.is_open() || !net.serves(authority.object())) {
    input.refuse_invoke(s, seq, cap::Operation::NetSend, static_cast<std::int32_t>(wire::OpError::Refused));
    return;
  }
  // No ground station has spoken yet: nowhere to send. Not a fault of the sender (its telemetry may start
  // before anyone listens), so counted apart. The address lives here, in the kernel, so that it survives the
  // rollbacks that wipe whatever ext_link learned in MC.
  const std::optional<sys::UdpAddress>& ground = net.ground();
  if (!ground) {
    net.count_unsent_no_ground();
    input.reply(s, seq, static_cast<std::int32_t>(wire::OpError::Refused));
    return;
  }
  // With signing on, the gate signs what the vehicle sends (the key stays in the kernel); a datagram it cannot
  // sign (not a well-formed MAVLink 2 frame) is not sent.
  std::optional<mavlink::Frame> signed_frame;
  if (net.signing()) {
    signed_frame = net.sign_outgoing(data, mavlink::SigningClock::now());
    if (!signed_frame) {
      if (net.may_log(wall())) log("network gate: not sent: a datagram of %zu bytes that is no MAVLink 2 frame to sign", data.size());
      input.reply(s, seq, static_cast<std::int32_t>(wire::OpError::Refused));
      return;
    }
  }
  if (auto ok = net.send(signed_frame ? signed_frame->view() : data, *ground); !ok) {
    if (net.may_log(wall())) log("network gate: send to %s: %s", ground->to_string().c_str(), ok.error().to_string().c_str());
    input.refuse_invoke(s, seq, cap::Operation::NetSend, static_cast<std::int32_t>(wire::OpError::Refused));
    return;
  }
  input.reply(s, seq, 0, data.size());
}

NetStats Kernel::net_stats() const { return impl_->net.stats(); }

std::optional<std::uint16_t> Kernel::network_port() const {
  if (!impl_->net.is_open()) return std::nullopt;
  return impl_->net.port();
}

}  // namespace rejuv::kernel
