// What the owners built alone ask of the rest of the kernel (impl.hpp), answered from Kernel::Impl: the
// Warden's peers (warden.hpp WardenPeers).
#include "impl.hpp"

namespace rejuv::kernel {

Nanos KernelWardenPeers::now() const {
  return k.now();
}
Nanos KernelWardenPeers::wall() const {
  return k.wall();
}
SrMode KernelWardenPeers::mode() const {
  return k.caps.mode();
}
bool KernelWardenPeers::rolls_back_on_violation() const {
  return k.sr && !k.stopping;
}
void KernelWardenPeers::log(const std::string& line) {
  k.log("%s", line.c_str());
}

void KernelWardenPeers::service_log(ServiceRuntime& s, std::string_view line) {
  k.service_log(s, wire::LogLevel::Info, line);
}

void KernelWardenPeers::publish_security_event(ServiceId s, std::uint32_t detail,
                                               rejuv_msg_SecurityEventKind kind) {
  k.router.publish_security_event(k.now(), s, detail, kind, k.caps.mode());
}

void KernelWardenPeers::request_rollback(std::string reason) {
  k.rejuvenator.request_rollback(std::move(reason));
}

void KernelWardenPeers::for_each_image(const std::function<void(const image::Image&)>& f) const {
  const image::ImageStore& store = k.rejuvenator.images();
  for (const Generation g : store.generations()) {
    for (const image::Image& im : store.find(g)->images) f(im);
  }
  for (const image::GenerationRecord& r : k.rejuvenator.retiring()) {
    for (const image::Image& im : r.images) f(im);
  }
}

bool KernelWardenPeers::knows_child(pid_t pid) const {
  if (k.rejuvenator.knows_process(pid, nullptr)) return true;
  for (const image::GenerationRecord& r : k.rejuvenator.retiring()) {
    for (const image::Image& im : r.images) {
      for (const sys::ChildProcess& c : im.copies) {
        if (c.pid() == pid) return true;
      }
    }
  }
  return k.rejuvenator.reaping(pid);
}

void KernelWardenPeers::settle_images() {
  k.rejuvenator.refresh_images();
  if (!k.rejuvenator.retiring().empty()) k.rejuvenator.finish_retiring(false);
}

bool KernelWardenPeers::checkpoint_running() const {
  return k.rejuvenator.coordinator().running() != nullptr;
}
bool KernelWardenPeers::owes_image(ServiceId s) const {
  return k.rejuvenator.coordinator().owes(s);
}
bool KernelWardenPeers::take_unheard_copy(ServiceId s) {
  return k.rejuvenator.take_unheard_copy(s);
}
void KernelWardenPeers::kill_and_reap_later(sys::ChildProcess p) {
  k.rejuvenator.kill_and_reap_later(std::move(p));
}

}  // namespace rejuv::kernel
