// SHA-256 (FIPS 180-4), for MAVLink 2 message signing (the signature is the first 48 bits of
// SHA-256(secret_key ‖ frame ‖ link id ‖ timestamp)), from OpenSSL's libcrypto (EVP): a kept implementation
// rather than one of our own. Checked against the FIPS 180-4 examples in tests/unit/mavlink.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>

namespace rejuv::mavlink {

using Sha256Digest = std::array<std::uint8_t, 32>;

// The digest of the concatenation of `parts`.
[[nodiscard]] Sha256Digest sha256(std::initializer_list<std::span<const std::byte>> parts);
[[nodiscard]] inline Sha256Digest sha256(std::span<const std::byte> bytes) { return sha256({bytes}); }

}  // namespace rejuv::mavlink
