// Connecting to the kernel (docs/design.md §2; docs/protocol.md "Boot"): the process made ready for images, the
// time page mapped, Hello sent and the boot script read through the channel's one decoder
// (rejuv/channel/boot.hpp); and the Service's end, which sends what is still queued, once.
#include <algorithm>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>

#include "rejuv/channel/boot.hpp"
#include "rejuv/sdk/memory_image.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/process.hpp"
#include "service_impl.hpp"

namespace rejuv::sdk {

Service::Service(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Service::~Service() {
  if (impl_ && impl_->workers != nullptr) {
    delete impl_->workers;  // NOLINT(cppcoreguidelines-owning-memory): stops and joins them
    impl_->workers = nullptr;
  }
  // One attempt, never a wait: a service leaving must not hang on a kernel that stopped reading.
  if (impl_) (void)channel::send_packed(impl_->channel, impl_->out);
}

SdkResult<void> Service::flush() { return impl_->flush(); }

SdkResult<std::unique_ptr<Service>> Service::connect(const ConnectOptions& options) {
  // First, before the service allocates much: malloc tied to the brk heap, the stack grown once, so that a
  // static build can take its images by written pages (memory_image.hpp). Where that fails, or the process
  // has more writable memory (whole_memory_tracked() says which), every image is by fork.
  (void)memory_image::prepare_self();
  auto impl = std::make_unique<Impl>();
  if (const char* name = std::getenv("REJUV_SERVICE"); name != nullptr) impl->name = name;
  if (!sys::fd_is_open(options.channel_fd) || !sys::fd_is_open(options.time_page_fd)) {
    return error(SdkError::NotAService, "fd 3 (channel) and fd 4 (time page) must be open: run under the kernel");
  }
  // The sandbox is the kernel's (installed before exec, docs/design.md §7 "Protection"): from the first Ready on,
  // this process opens nothing and maps nothing executable.
  memory_image::opens_done();
  // Not dumpable: no process of its uid (its own images, say) can open its /proc/<pid>/mem or ptrace it.
  // Its images inherit this at fork (frozen_image). A kernel without root asks it to stay dumpable: it could
  // not open the pagemap of a non-dumpable service otherwise (supervisor.cpp), and every image would be by fork.
  const char* keep = std::getenv(wire::kKeepDumpableEnv);
  if (keep == nullptr || std::string_view(keep) != "1") {
    if (auto nd = sys::make_non_dumpable(); !nd) return error(SdkError::NotAService, nd.error().to_string());
  }
  auto page = clock::TimePageReader::map(options.time_page_fd);
  if (!page) return error(SdkError::NotAService, "time page: " + page.error().to_string());
  impl->time = std::move(*page);
  impl->channel = sys::SeqPacket(sys::UniqueFd(options.channel_fd));
  // Blocking for reads, so that waiting for a frame is the read itself (receive_batch, Wait::ForOne); every
  // read that must not wait and every send say so per call (MSG_DONTWAIT).
  if (auto nb = sys::set_nonblocking(options.channel_fd, false); !nb) return io_error(nb.error());

  // Hello, then Boot, BootCap × n, BootParam × m, BootEnd (docs/protocol.md "Boot").
  if (!impl->tx.build(wire::FrameKind::Hello, 0, 0, wire::kProtocolVersion)) return error(SdkError::Protocol);
  if (auto s = impl->send(impl->tx.bytes()); !s) {
    if (s.error().code == SdkError::ChannelIo) s.error().code = SdkError::NotAService;
    return std::unexpected(s.error());
  }
  const auto next = [&]() -> SdkResult<wire::FrameView> {
    auto got = impl->receive(true);
    if (!got) return std::unexpected(got.error());
    auto frame = wire::decode(std::span<const std::byte>(impl->rx.data(), **got), wire::Direction::ToService);
    if (!frame) return error(SdkError::Protocol, std::string("boot: ") + std::string(wire::to_string(frame.error())));
    return *frame;
  };
  // The whole script is decoded and checked before the service builds anything from it.
  channel::BootDecoder script;
  for (bool done = false; !done;) {
    auto frame = next();
    if (!frame) return std::unexpected(frame.error());
    auto took = script.take(*frame);
    if (!took) {
      return error(took.error().error == channel::BootError::VersionMismatch ? SdkError::VersionMismatch : SdkError::Protocol,
                   channel::to_string(took.error()));
    }
    done = *took;
  }
  const channel::BootIdentity who = script.identity();
  impl->id = who.service;
  if (impl->name.empty()) impl->name = std::string(who.name);
  std::size_t max_slot = 0;  // below wire::kCSpaceSlots: the decoder refuses a slot out of the CSpace
  for (std::size_t i = 0; i < script.cap_count(); ++i) {
    const channel::BootCapEntry c = script.cap(i);
    impl->caps.push_back(CapInfo{.object = std::string(c.object), .slot = c.slot, .kind = c.kind, .rights = c.rights,
                                 .type = std::string(c.type), .payload_size = c.payload_size});
    max_slot = std::max<std::size_t>(max_slot, c.slot.value());
  }
  for (std::size_t i = 0; i < script.param_count(); ++i) {
    const channel::BootParamEntry p = script.param(i);
    impl->params.push_back(Param{.name = std::string(p.name), .number = p.number, .text = std::string(p.text),
                                 .is_text = p.is_text, .integer = p.integer, .is_integer = p.is_integer});
  }
  impl->subscription_by_slot.assign(max_slot + 1, nullptr);
  for (const Param& p : impl->params) {
    if (p.name == "clock" && p.is_text) impl->lockstep = p.text != "realtime";
  }
  return std::unique_ptr<Service>(new Service(std::move(impl)));
}

}  // namespace rejuv::sdk
