// Images by memory instead of by fork alone (docs/design.md §7, the paper's §V-B create_checkpoint and §V-C rollback,
// which copy the task's memory inside the kernel module).
//
// A static, single-threaded service keeps all of its private writable memory in three regions: data+bss, the
// brk heap and its stack (prepare_self ties malloc to the brk heap and grows the stack once, so that neither
// moves). Two uses:
//
// - The runtime's images by written pages (services/sdk/src/image.cpp, docs/protocol.md "Checkpoint and
//   rollback"). The service tracks its writes (track_writes_self: userfaultfd write-protection in its
//   asynchronous mode, read and re-armed with PAGEMAP_SCAN). A checkpoint whose base image the kernel still
//   holds takes no fork: the service saves its context (REJUV_IMAGE_SAVE), copies the pages written since
//   its base image into a sealed memfd (copy_written_self) and goes on. Off the critical path, a frozen copy
//   of the base image forks, applies the pages to itself (apply_written) on its standby stack, and is the
//   new image; resumed, it jumps into the saved context (resume_saved).
// - bench/image, which measures images by fork, by copy (read_process/load_self into holders forked from a
//   zygote) and by written pages side by side (docs/performance.md).
//
// The rule that keeps an image equal to its process: a copy of an image writes only its standby stack and
// the scratch mapping (this process's tracking state, the scan buffers) until it is resumed — never data,
// heap or stack, which are what an image is made of. Bytes it must write there (the frames of the call that
// took the image, below the saved context) are dead once the saved context is resumed.
//
// Single-threaded processes of one static executable only (their regions are the same in every copy);
// whole_memory_tracked() says whether this process is one.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "rejuv/sys/fd.hpp"

namespace rejuv::memory_image {

struct Region {
  std::uintptr_t lo = 0;
  std::uintptr_t hi = 0;
  [[nodiscard]] std::size_t size() const { return hi > lo ? hi - lo : 0; }
  friend bool operator==(const Region&, const Region&) = default;
};

// The private writable memory of a service at one moment; also its wire form (trivially copyable).
struct Layout {
  Region data;   // .data + .bss (fixed)
  Region heap;   // brk heap: start fixed, end as the image had it
  Region stack;  // from below the saved stack pointer to the top of the stack (argv, environment, auxv)
  [[nodiscard]] std::size_t bytes() const { return data.size() + heap.size() + stack.size(); }
  friend bool operator==(const Layout&, const Layout&) = default;
};

// Largest image accepted (a service reporting more is refused, not copied).
inline constexpr std::size_t kMaxImageBytes = std::size_t{64} << 20;

// What is wrong with a layout a service reported, or nullptr: every region non-empty, page-aligned, in
// order data < heap < stack without overlap, at most kMaxImageBytes in all.
[[nodiscard]] const char* check(const Layout& layout);

// ---- in the service ----

// Once, before the service allocates much and before it forks anything.
[[nodiscard]] sys::SysResult<void> prepare_self();
// Prepared, and no private writable mapping beyond data+bss, heap and stack (a dynamically linked or
// sanitized build has libraries' data): only then is an image by written pages the whole process.
[[nodiscard]] bool whole_memory_tracked();
// An address below every local of the calling function (the address of a local of a callee).
[[nodiscard]] std::uintptr_t stack_pointer();
// The layout now, with the stack from `stack_pointer` (less a margin for the red zone) to its top.
[[nodiscard]] Layout layout_at(std::uintptr_t stack_pointer);

// A saved execution context. REJUV_IMAGE_SAVE(ctx) is 0 when it saves and 1 when resume_saved(ctx) comes
// back to it (in a holder, after load_self). Like setjmp: the function that saves must still be running
// when the image is copied, and locals it changes after saving are undefined after the return with 1.
using Context = void* [5];
#define REJUV_IMAGE_SAVE(ctx) __builtin_setjmp(ctx)  // NOLINT(cppcoreguidelines-macro-usage)

// Runs fn(arg) on the standby stack; never returns (a zygote or holder lives there, so that loading an image
// over the main stack does not pull the ground from under it). In a process prepare_self failed in, on the
// current stack instead (its images are by fork only: nothing is ever loaded over it).
[[noreturn]] void run_on_standby_stack(void (*fn)(int), int arg);

// In a holder (on the standby stack): grows the heap and the stack to the image's and reads `image` (the
// three regions back to back, as read_process() wrote them) over this process's memory. EINVAL if the
// fixed parts of the layout are not this executable's. If the image's process tracked its writes, the
// holder tracks its own from the image as loaded.
[[nodiscard]] sys::SysResult<void> load_self(const Layout& layout, int image_fd);

// In a loaded holder: continues in the saved context (REJUV_IMAGE_SAVE returns 1 there).
[[noreturn]] void resume_saved(Context& ctx);

// ---- images by written pages (a checkpoint copies only what changed since the previous one) ----
// Starts tracking writes to this process's data+bss, its heap as it is now and its whole stack mapping:
// userfaultfd write-protection in its asynchronous mode (UFFD_FEATURE_WP_ASYNC), read and re-armed with the
// PAGEMAP_SCAN ioctl (Linux ≥ 6.7). A process forked from this one does not inherit the tracking (call it
// again there, e.g. in a holder after load_self). The error where the kernel lacks either.
[[nodiscard]] sys::SysResult<void> track_writes_self();
// From here on track_writes_self opens nothing (its pagemap comes from the kernel): a service's sandbox
// allows no open once it is booted (docs/design.md §7 "Protection"). Called by the SDK at the end of its boot.
void opens_done();
// Whether track_writes_self() succeeded in this process.
[[nodiscard]] bool tracking_writes();
// In a process forked from a tracking one: drops the descriptors it inherited (they name the parent).
void forget_tracking();
// The layout written pages are relative to: data+bss, the heap now, the whole stack mapping.
[[nodiscard]] Layout tracked_layout();
// Tracking, and the heap and stack still where tracking started, with `stack_pointer` inside the tracked
// stack: the written pages are then the whole difference from the base image.
[[nodiscard]] bool layout_unchanged(std::uintptr_t stack_pointer);
// Pages written since tracking started or since the last call, write-protected again, copied into `fd` as
// records: the addresses (std::uint64_t each) from offset 0, the pages from kWrittenPagesAt on, in order.
// Returns how many. Save the context first: the pages are the image as of now. `fd` −1: only re-arms.
// `pagemap`: this process's /proc/<pid>/pagemap opened by someone allowed to (its kernel), or −1 for the
// one track_writes_self opened itself, if it could.
[[nodiscard]] sys::SysResult<std::size_t> copy_written_self(int fd, int pagemap = -1);
// In a copy of the base image, on the standby stack: writes `pages` pages of a record file that
// copy_written_self filled (and that nobody can change any more: a sealed memfd) over this process's
// memory. EINVAL if an address is not a page of this process's data+bss, heap or stack, or out of order.
[[nodiscard]] sys::SysResult<void> apply_written(int fd, std::size_t pages);
// A record file for copy_written_self, made off the critical path: a sealable memfd whose first pages are
// allocated already (twice what the last image carried, at least kRecordPagesAhead): allocating and
// zeroing them inside copy_written_self costs ≈ 1.5 µs a page here, two thirds of its copy.
[[nodiscard]] sys::SysResult<sys::UniqueFd> make_record_file();
inline constexpr std::size_t kRecordPagesAhead = 16;
// In a copy of an image, after every fork that made it or that it made: makes the pages the last image by
// written pages carried (this service's working set: what copy_written_self found in the live process, what
// apply_written wrote here) this process's own, each by writing one of its bytes back as it is. The fork
// left them shared copy-on-write; resumed, the copy would take a copy-on-write fault on each first write
// (≈ 3 µs here), one copy after the other on a rollback's critical path. Contents are unchanged: an image
// stays equal to its process. At most kMaxTouchedPages.
void touch_working_set();
inline constexpr std::size_t kMaxTouchedPages = 256;
inline constexpr std::size_t kPageBytes = 4096;
inline constexpr std::size_t kMaxWrittenPages = 4096;
inline constexpr std::size_t kWrittenPagesAt = kMaxWrittenPages * sizeof(std::uint64_t);
inline constexpr std::size_t kMaxWrittenBytes = kWrittenPagesAt + kMaxWrittenPages * kPageBytes;  // a full record file

// ---- in the kernel ----

// Where the page at `address` lies in an image of `layout` (its three regions back to back, as read_process
// writes it and load_self reads it); nullopt if it lies in none of them.
[[nodiscard]] std::optional<std::size_t> offset_in_image(const Layout& layout, std::uintptr_t address);

// Copies `layout` of process `pid` (stopped at its save point) into `into` (layout.bytes() long).
[[nodiscard]] sys::SysResult<void> read_process(pid_t pid, const Layout& layout, std::span<std::byte> into);

}  // namespace rejuv::memory_image
