#include "rejuv/mavlink/sha256.hpp"

#include <openssl/evp.h>

#include <memory>

#include "rejuv/core/result.hpp"

namespace rejuv::mavlink {

Sha256Digest sha256(std::initializer_list<std::span<const std::byte>> parts) {
  const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  Sha256Digest out{};
  unsigned int length = 0;
  // SHA-256 of a few hundred bytes in memory fails only when libcrypto cannot allocate: a broken invariant.
  bool ok = ctx != nullptr && EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) == 1;
  for (const std::span<const std::byte> part : parts) ok = ok && EVP_DigestUpdate(ctx.get(), part.data(), part.size()) == 1;
  ok = ok && EVP_DigestFinal_ex(ctx.get(), out.data(), &length) == 1 && length == out.size();
  REJUV_ASSERT(ok, "libcrypto's SHA-256 failed");
  return out;
}

}  // namespace rejuv::mavlink
