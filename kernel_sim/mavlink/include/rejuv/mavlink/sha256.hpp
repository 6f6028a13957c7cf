// SHA-256 (FIPS 180-4), for MAVLink 2 message signing (the signature is the first 48 bits of
// SHA-256(secret_key ‖ frame ‖ link id ‖ timestamp)). Written here rather than taken from a crypto library so
// that the kernel gains no dependency; checked against the FIPS 180-4 examples in tests/unit/mavlink.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace rejuv::mavlink {

using Sha256Digest = std::array<std::uint8_t, 32>;

// Incremental SHA-256: update() any number of times, then finish() once.
class Sha256 {
 public:
  void update(std::span<const std::byte> bytes);
  void update(std::span<const std::uint8_t> bytes) { update(std::as_bytes(bytes)); }
  [[nodiscard]] Sha256Digest finish();

 private:
  void block(const std::uint8_t* p);
  std::array<std::uint32_t, 8> h_{0x6a09e667U, 0xbb67ae85U, 0x3c6ef372U, 0xa54ff53aU,
                                  0x510e527fU, 0x9b05688cU, 0x1f83d9abU, 0x5be0cd19U};
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t total_bytes_ = 0;
};

[[nodiscard]] Sha256Digest sha256(std::span<const std::byte> bytes);

}  // namespace rejuv::mavlink
