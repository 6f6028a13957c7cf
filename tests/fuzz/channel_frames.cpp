// Fuzz target: the kernel's channel input (kernel_sim/kernel channel_input.cpp, router.cpp; docs/protocol.md):
// bytes a sandboxed service sends, driven through a real Kernel — created from a small graph (the
// multi-process tests' policy, five services, SR off) with TimeMaster::Manual — its framing, protocol phases,
// request handlers (Subscribe, Invoke of every operation, timers, logs, Idle, image frames) and its router
// (staged publications, deliveries, the SecurityEvent of every denial), with lockstep steps in between.
// No process is spawned: the services sit on socket pairs through the kernel's one test seam
// (Kernel::attach_scripted_services / inject_datagram), and the harness drains their ends.
//
// Input: u8 flags (bit 0: boot every service first — Hello and Ready; refused as "after boot" when the
// session's kernel has booted them already — so that most inputs reach the request handlers), then operations: u8 op; op 0xFF: a lockstep step 1 ms on; otherwise a record
// (u16 length, bytes) sent as one datagram by service op % 5.
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_input.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"

namespace {

using rejuv::kernel::Kernel;
constexpr int kMaxOperations = 64;

std::string launch_text() {
  std::string t = "name: \"fuzz\"\npolicy: \"test.policy.pbtxt\"\nclock: LOCKSTEP\nseed: 1\n";
  const auto svc = [&](const std::string& name, const std::string& uses) {
    t += "services { name: \"" + name + "\" executable: \"/bin/true\" " + uses + " }\n";
  };
  svc("source", "uses { object: \"numbers\" rights: \"W\" }");
  svc("echo", "uses { object: \"numbers\" rights: \"R\" } uses { object: \"echoes\" rights: \"W\" }");
  svc("sink", "uses { object: \"numbers\" rights: \"R\" } uses { object: \"echoes\" rights: \"R\" } "
              "uses { object: \"security_event\" rights: \"R\" } uses { object: \"digest\" rights: \"W\" }");
  svc("stall", "uses { object: \"numbers\" rights: \"R\" }");
  svc("intruder", "uses { object: \"numbers\" rights: \"R\" }");
  t += "mission { waypoints { down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 600 }\n";
  return t;
}

std::unique_ptr<Kernel> make_kernel() {
  static const std::filesystem::path where =
      std::filesystem::path(REJUV_SOURCE_DIR) / "tests/multiproc/graphs/fuzz.launch.pbtxt";
  auto graph = rejuv::launch::parse_launch(launch_text(), where);
  if (!graph) std::abort();  // the harness's own graph: a broken harness, not a finding
  rejuv::kernel::KernelOptions o;
  o.time_master = rejuv::kernel::TimeMaster::Manual;
  o.placement = rejuv::kernel::KernelOptions::Placement::Spread;  // never pin the fuzzer
  o.shutdown_grace = std::chrono::milliseconds{0};                // no process to wait for
  o.log = nullptr;
  auto k = Kernel::create(std::move(*graph), std::move(o));
  if (!k) std::abort();
  return std::move(*k);
}

void send(Kernel& k, std::uint32_t service, rejuv::wire::FrameKind kind, std::uint64_t aux = 0) {
  rejuv::wire::FrameBuffer fb;
  if (fb.build(kind, 0, 0, aux)) k.inject_datagram(rejuv::ServiceId(service), fb.bytes());
}

void drain(std::vector<rejuv::sys::SeqPacket>& ends) {
  alignas(8) static std::array<std::byte, rejuv::wire::kMaxFrameBytes> buf{};
  for (rejuv::sys::SeqPacket& end : ends) {
    if (!end.valid()) continue;
    for (int i = 0; i < 4096; ++i) {
      auto r = end.receive(buf);
      if (!r || r->closed) break;
    }
  }
}

// A kernel with its services attached. Creating one costs milliseconds under ASan (the whole graph: policy,
// audit, capability system, broker, time page, epoll), so one serves kInputsPerKernel inputs in a row —
// longer sessions, as a real service's — and is replaced sooner when a run stopped (a lost service ends
// it). Replaying one file always starts from a fresh kernel; a crash that needs the inputs before it shows
// as a crash of the replay of the whole corpus directory, in order (replay_main.cpp sorts the files).
constexpr int kInputsPerKernel = 32;
struct Session {
  std::unique_ptr<Kernel> kernel;
  std::vector<rejuv::sys::SeqPacket> ends;
  int inputs = 0;
  std::int64_t t_ms = 0;
};

Session& session() {
  static Session s;
  if (!s.kernel || s.inputs >= kInputsPerKernel || s.kernel->stop_reason()) {
    s.ends.clear();
    s.kernel.reset();
    s.kernel = make_kernel();
    auto attached = s.kernel->attach_scripted_services();
    if (!attached) std::abort();
    s.ends = std::move(*attached);
    s.inputs = 0;
    s.t_ms = 0;
  }
  ++s.inputs;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rejuv::fuzz::Input in(data, size);
  const std::uint8_t flags = in.u8();
  Session& session_now = session();
  Kernel* k = session_now.kernel.get();
  std::vector<rejuv::sys::SeqPacket>& ends = session_now.ends;
  const auto services = static_cast<std::uint32_t>(k->service_count());
  if ((flags & 1U) != 0) {
    for (std::uint32_t s = 0; s < services; ++s) {
      send(*k, s, rejuv::wire::FrameKind::Hello, rejuv::wire::kProtocolVersion);
      send(*k, s, rejuv::wire::FrameKind::Ready);
    }
    drain(ends);
  }
  std::int64_t& t_ms = session_now.t_ms;
  for (int i = 0; i < kMaxOperations && !in.empty(); ++i) {
    const std::uint8_t op = in.u8();
    if (op == 0xFF) {
      if (k->stop_reason()) break;
      (void)k->step(std::chrono::milliseconds{++t_ms});
    } else {
      k->inject_datagram(rejuv::ServiceId(op % services), in.record());
    }
    drain(ends);
  }
  // What the kernel reports must stay consistent with what it was given.
  for (std::uint32_t s = 0; s < services; ++s) {
    const rejuv::kernel::ServiceStats st = k->stats(rejuv::ServiceId(s));
    if (st.bad_frames > st.frames_in) std::abort();
  }
  return 0;
}
