// What a sanitizer build (the asan and tsan presets) changes in a service's sandbox.
#pragma once

#include <cstdint>

// Which sanitizer this translation unit is built with: GCC says so with __SANITIZE_ADDRESS__ /
// __SANITIZE_THREAD__, Clang (the tsan preset is built with clang-16) with __has_feature.
#if defined(__SANITIZE_ADDRESS__)
#define REJUV_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define REJUV_ASAN 1
#endif
#endif
#if defined(__SANITIZE_THREAD__)
#define REJUV_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define REJUV_TSAN 1
#endif
#endif

namespace rejuv::sys {

// The address space a sanitizer's runtime reserves in every process at start, which RLIMIT_AS counts (0 in a
// build without one). AddressSanitizer on x86-64 (47-bit addresses): its shadow memory, 16 TiB from
// 0x7fff8000, and its allocator's region, 4 TiB at 0x600000000000, all reserved before main. A service's
// RLIMIT_AS is its own memory on top of this (kernel sandbox.cpp). ThreadSanitizer reserves nearly the whole
// address space: a TSan build sets no RLIMIT_AS.
#if defined(REJUV_ASAN)
inline constexpr std::uint64_t kSanitizerAddressSpace = std::uint64_t{20} << 40U;
#else
inline constexpr std::uint64_t kSanitizerAddressSpace = 0;
#endif

}  // namespace rejuv::sys
