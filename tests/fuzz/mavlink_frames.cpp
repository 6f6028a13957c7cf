// Fuzz target: the MAVLink 2 codec (kernel_sim/mavlink, docs/mavlink.md) and what reads network bytes with
// it — the kernel gate's signature check and ext_link's handling of a relayed frame. Bytes → decode → a
// decoded message must encode back (same envelope) to a frame that decodes to the same message; the
// signature checker and ExtLink::on_datagram must refuse or accept without crashing.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"
#include "rejuv/services/ext_link/ext_link.hpp"

namespace {

// Equal as the wire sees it: float fields compared by bits (NaN ≠ NaN otherwise).
bool same_bytes(const rejuv::mavlink::Message& a, const rejuv::mavlink::Message& b) {
  const rejuv::mavlink::Frame fa = rejuv::mavlink::encode(a, {});
  const rejuv::mavlink::Frame fb = rejuv::mavlink::encode(b, {});
  return fa.size == fb.size && std::equal(fa.view().begin(), fa.view().end(), fb.view().begin());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  if (auto p = rejuv::mavlink::decode(bytes)) {
    const rejuv::mavlink::Frame again = rejuv::mavlink::encode(
        p->message, {.seq = p->header.seq, .sysid = p->header.sysid, .compid = p->header.compid});
    auto back = rejuv::mavlink::decode(again.view());
    if (!back || !same_bytes(back->message, p->message)) std::abort();
  }
  rejuv::mavlink::SignatureChecker checker(rejuv::mavlink::SigningKey{});
  (void)checker.check(bytes, rejuv::mavlink::SigningTime{});  // the clock at the epoch: any timestamp is recent
  // home at the square's start, 3 m up; the default bounds (the geofence commander also applies); the launch
  // mission home alone; home on Earth PX4 SITL's (items in global frames are converted against it)
  const rejuv::flight::PathWaypoint home{.p_N_m = Eigen::Vector3d(0.0, 0.0, -3.0), .yaw_rad = 0.0};
  rejuv::services::ExtLink link(rejuv::services::ExtLink::UploadGuard{.home = home, .bounds = {}},
                                rejuv::flight_io::MissionSpec{.waypoints = {home}, .acceptance_radius_m = 0.05, .from_defaults = false});
  link.set_home(rejuv::mavlink::kPx4SitlHome);
  (void)link.on_datagram(bytes, rejuv::Nanos{0});
  (void)link.on_datagram(bytes, rejuv::Nanos{1});  // a retransmission of the same datagram
  return 0;
}
