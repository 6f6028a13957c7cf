// Fuzz target: the ground-link decoder (services/ext_link link_protocol.cpp, docs/link_protocol.md) and
// ext_link's handling of a relayed datagram. Bytes → decode (both directions) → a decoded message must encode
// back to a datagram that decodes to the same message; the vehicle side also goes through ExtLink::on_datagram.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "rejuv/services/ext_link/ext_link.hpp"
#include "rejuv/services/ext_link/link_protocol.hpp"

namespace {

void round_trip(const rejuv::link::Message& m, rejuv::link::Direction d) {
  const rejuv::link::Datagram again = rejuv::link::encode(m);
  auto back = rejuv::link::decode(again.view(), d);
  // Bit-exact equality would fail on −0.0 vs 0.0 never, on NaN always; decode refuses NaN, so == holds.
  if (!back || !(*back == m)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  for (const auto d : {rejuv::link::Direction::ToVehicle, rejuv::link::Direction::ToGround}) {
    if (auto m = rejuv::link::decode(bytes, d)) round_trip(*m, d);
  }
  // home at the square's start, 3 m up; the default bounds (the geofence commander also applies)
  rejuv::services::ExtLink link(rejuv::services::ExtLink::UploadGuard{.home = {.p_N_m = Eigen::Vector3d(0.0, 0.0, -3.0), .yaw_rad = 0.0}, .bounds = {}});
  (void)link.on_datagram(bytes, rejuv::Nanos{0});
  (void)link.on_datagram(bytes, rejuv::Nanos{1});  // a retransmission of the same datagram
  return 0;
}
