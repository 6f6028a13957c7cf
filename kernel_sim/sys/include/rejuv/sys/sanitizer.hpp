// What a sanitizer build (the asan and tsan presets) changes: in a service's sandbox, and in what memory means.
#pragma once

#include <malloc.h>

#include <cstddef>
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

#if defined(REJUV_ASAN) || defined(REJUV_TSAN)
#define REJUV_SANITIZED 1
// The sanitizer runtime's (sanitizer/allocator_interface.h, a header GCC does not install).
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();  // NOLINT(bugprone-reserved-identifier)
#endif

namespace rejuv::sys {

#if defined(REJUV_SANITIZED)
inline constexpr bool kSanitizerBuild = true;
#else
inline constexpr bool kSanitizerBuild = false;
#endif

// The bytes this process's allocations hold: malloc's count (mallinfo2: every arena and mmapped block), or in
// a sanitizer build its allocator's, which malloc's does not see. A leak grows this; the RSS also moves with
// pages touched and freed memory not given back, and in a sanitizer build with its shadow of every address
// touched (so a sanitizer build's RSS is not a leak's measure).
inline std::uint64_t heap_in_use_bytes() {
#if defined(REJUV_SANITIZED)
  return __sanitizer_get_current_allocated_bytes();
#else
  const struct mallinfo2 m = ::mallinfo2();
  return m.uordblks + m.hblkhd;
#endif
}

// The address space a sanitizer's runtime reserves in every process at start, which RLIMIT_AS counts (0 in a
// build without one). AddressSanitizer on x86-64 (47-bit addresses): its shadow memory, 16 TiB from
// 0x7fff8000, and its allocator's region, 4 TiB at 0x600000000000, all reserved before main. A service's
// RLIMIT_AS is its own memory on top of this (kernel warden.cpp). ThreadSanitizer reserves nearly the whole
// address space: a TSan build sets no RLIMIT_AS.
#if defined(REJUV_ASAN)
inline constexpr std::uint64_t kSanitizerAddressSpace = std::uint64_t{20} << 40U;
#else
inline constexpr std::uint64_t kSanitizerAddressSpace = 0;
#endif

}  // namespace rejuv::sys
