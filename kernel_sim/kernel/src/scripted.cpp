// The test seam of the channel-input fuzzer (tests/fuzz/channel_frames.cpp, kernel.hpp): services on socket
// pairs with no process, and datagrams handed to the same code read_channel runs after a read. Nothing in a
// run uses it; it is a file of its own so that the seam stays visible and small.
#include "impl.hpp"

namespace rejuv::kernel {

namespace {
KernelError seam_error(KernelError::Kind kind, std::string message) {
  return KernelError{.kind = kind, .message = std::move(message), .findings = {}};
}
}  // namespace

Result<std::vector<sys::SeqPacket>, KernelError> Kernel::attach_scripted_services() {
  Impl& k = *impl_;
  if (k.booted || k.shut_down) return fail(seam_error(KernelError::Kind::Boot, "already booted or shut down"));
  std::vector<sys::SeqPacket> ends(k.services.size());
  for (ServiceRuntime& s : k.services) {
    if (s.config.skip) continue;
    auto pair = sys::SeqPacket::pair(sys::Blocking::No);
    if (!pair) return fail(seam_error(KernelError::Kind::System, pair.error().to_string()));
    s.proc.channel = std::move(pair->first);
    ends[s.id.value()] = std::move(pair->second);
    s.proc.scripted = true;
    s.proc.spawned();
    s.proc.spawned_at = k.wall();
    s.sandbox.limiter.last = s.proc.spawned_at;
    if (auto ok = k.epoll.add(s.proc.channel.fd(), token(Source::Channel, s.id.value())); !ok) {
      return fail(seam_error(KernelError::Kind::System, ok.error().to_string()));
    }
  }
  k.wall_start = k.wall();
  k.booted = true;
  return ends;
}

void Kernel::inject_datagram(ServiceId service, std::span<const std::byte> datagram) {
  Impl& k = *impl_;
  if (service.value() >= k.services.size()) return;
  ServiceRuntime& s = k.services[service.value()];
  if (!s.proc.scripted || !s.live() || !s.proc.channel.valid() || k.shut_down) return;
  k.input.receive_datagram(
      s, datagram.size() > wire::kMaxFrameBytes ? datagram.first(wire::kMaxFrameBytes) : datagram);
  k.router.drain_denials();
}

}  // namespace rejuv::kernel
