#include "rejuv/sdk/memory_image.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <linux/userfaultfd.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <ucontext.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>

#include "rejuv/sys/sanitizer.hpp"

namespace rejuv::memory_image {

namespace {

constexpr std::uintptr_t kPage = kPageBytes;
constexpr std::size_t kStandbyStackBytes = std::size_t{256} << 10;
constexpr std::size_t kStackReserve = std::size_t{256} << 10;  // the stack grown by this much at start
constexpr int kHeapTopPad = 256 << 10;                        // malloc grows the heap by this much more
// Below the saved stack pointer: the red zone and the frames of the calls the service makes after saving
// (they are scratch in the image, but copying a little more keeps the page that holds the pointer whole).
constexpr std::uintptr_t kStackMargin = 512;

std::uintptr_t page_down(std::uintptr_t a) { return a & ~(kPage - 1); }
std::uintptr_t page_up(std::uintptr_t a) { return page_down(a + kPage - 1); }

// The fixed facts of this executable's address space, the same in every process forked from it. They live
// in .bss and are written once, by prepare_self before any copy exists, so an image has the same values.
struct Self {
  Region data;
  std::uintptr_t heap_lo = 0;
  std::uintptr_t stack_lo = 0;  // the stack mapping's bottom when the maps were read (after pre-growing it)
  std::uintptr_t stack_hi = 0;
  std::uintptr_t standby_lo = 0;
  bool other_writable = false;  // a private writable mapping beyond data+bss, heap and stack (a library's)
};
Self self;

// Write tracking (track_writes_self). Linux ≥ 6.7; Debian 12's linux/fs.h and linux/userfaultfd.h predate it.
constexpr int kUffdUserModeOnly = 1;  // UFFD_USER_MODE_ONLY (Linux ≥ 5.11)
constexpr std::uint64_t kUffdFeatureWpUnpopulated = 1U << 13;
constexpr std::uint64_t kUffdFeatureWpAsync = 1U << 15;
constexpr std::uint64_t kPageIsWritten = 1U << 1;
constexpr std::uint64_t kScanWpMatching = 1U << 0;
constexpr std::uint64_t kScanCheckWpAsync = 1U << 1;
struct PageRegion {
  std::uint64_t start, end, categories;
};
struct PmScanArg {
  std::uint64_t size, flags, start, end, walk_end, vec, vec_len, max_pages, category_inverted, category_mask,
      category_anyof_mask, return_mask;
};
constexpr unsigned long kPagemapScan = _IOWR('f', 16, PmScanArg);

// Above the channel's fd 3 and anything a service passes around.
int high_fd(int fd) {
  if (fd < 0) return fd;
  const int moved = ::fcntl(fd, F_DUPFD_CLOEXEC, 100);
  ::close(fd);
  return moved;
}

// This process's own mutable state of the scheme and what copy_written_self fills: outside every tracked
// region (mapped on its own, like the standby stack), so that neither marks a page written nor differs
// between an image and the process it was taken from in a page the image is made of (a copy of an image
// writes here, never into data, heap or stack, until it is resumed).
struct Scratch {
  int uffd = -1;  // write tracking (track_writes_self), this process's own
  int pagemap = -1;
  Layout tracked{};
  void (*standby_fn)(int) = nullptr;
  int standby_arg = -1;
  ucontext_t standby_context;
  PmScanArg arg;  // the kernel writes it back (walk_end): not on the tracked stack either
  std::array<PageRegion, 512> scanned;
  std::array<std::uint64_t, kMaxWrittenPages> addresses;
  std::size_t written = 0;  // how many of `addresses` the last copy_written_self or apply_written found
  std::array<iovec, 512> pages;
};
Scratch* scratch = nullptr;

// Mapped by prepare_self, before the zygote is forked, so that every holder has it at the same address.
Scratch* map_scratch() {
  if (scratch != nullptr) return scratch;
  void* m = ::mmap(nullptr, sizeof(Scratch), PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (m == MAP_FAILED) return nullptr;
  scratch = new (m) Scratch{};
  return scratch;
}

// /proc/self/maps read with plain system calls into a static buffer (no allocation: it runs before and
// while malloc is being tied to the brk heap).
sys::SysResult<void> read_maps() {
  std::array<char, 4096> exe{};
  const ssize_t exe_len = ::readlink("/proc/self/exe", exe.data(), exe.size() - 1);
  if (exe_len <= 0) return sys::last_error("readlink(/proc/self/exe)");
  static std::array<char, 64 * 1024> buf{};
  const int fd = ::open("/proc/self/maps", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return sys::last_error("open(/proc/self/maps)");
  std::size_t used = 0;
  for (;;) {
    const ssize_t n = ::read(fd, buf.data() + used, buf.size() - 1 - used);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    used += static_cast<std::size_t>(n);
  }
  ::close(fd);
  buf[used] = '\0';
  bool in_data = false;
  for (char* line = buf.data(); line != nullptr && *line != '\0';) {
    char* next = std::strchr(line, '\n');
    if (next != nullptr) *next++ = '\0';
    unsigned long lo = 0;
    unsigned long hi = 0;
    std::array<char, 8> perms{};
    int path_at = 0;
    if (std::sscanf(line, "%lx-%lx %4s %*s %*s %*s %n", &lo, &hi, perms.data(), &path_at) >= 3) {
      const char* path = path_at > 0 ? line + path_at : "";
      const bool rw_private = std::strcmp(perms.data(), "rw-p") == 0;
      if (in_data && rw_private && lo == self.data.hi && (*path == '\0' || std::strcmp(path, exe.data()) == 0)) {
        self.data.hi = hi;  // .bss (anonymous) right after .data
      } else {
        in_data = false;
        if (self.data.lo == 0 && rw_private && std::strcmp(path, exe.data()) == 0) {
          self.data = Region{lo, hi};
          in_data = true;
        }
      }
      const bool heap = std::strcmp(path, "[heap]") == 0;
      const bool stack = std::strcmp(path, "[stack]") == 0;
      if (heap) self.heap_lo = lo;
      if (stack) {
        self.stack_lo = lo;
        self.stack_hi = hi;
      }
      if (rw_private && !in_data && !heap && !stack) self.other_writable = true;
    }
    line = next;
  }
  if (self.data.lo == 0 || self.stack_hi == 0) return std::unexpected(sys::SysError{"/proc/self/maps: no data or stack", ENOENT});
  if (self.heap_lo == 0) self.heap_lo = reinterpret_cast<std::uintptr_t>(::sbrk(0));  // no heap yet
  return {};
}

void standby_entry() { scratch->standby_fn(scratch->standby_arg); ::_exit(3); }

// Set once a process of this executable tracks its writes; the same in its images (written only while false).
bool tracks_writes_flag = false;
// Set by opens_done() at the end of a service's boot (and so in all its images).
bool no_more_opens = false;

// Data+bss, the heap as it is now and the whole stack mapping: what tracking covers and pages may land in.
Layout whole_layout() {
  return Layout{.data = self.data,
                .heap = Region{self.heap_lo, page_up(reinterpret_cast<std::uintptr_t>(::sbrk(0)))},
                .stack = Region{self.stack_lo, self.stack_hi}};
}

}  // namespace

const char* check(const Layout& l) {
  for (const Region& r : {l.data, l.heap, l.stack}) {
    if (r.hi <= r.lo) return "an empty region";
    if (r.lo % kPage != 0 || r.hi % kPage != 0) return "a region not on page boundaries";
  }
  if (l.data.hi > l.heap.lo || l.heap.hi > l.stack.lo) return "regions out of order or overlapping";
  if (l.bytes() > kMaxImageBytes) return "larger than the largest image";
  return nullptr;
}

// Grows the stack mapping `bytes` below the caller's frame, so that it need not grow later (a tracked
// layout covers the stack mapping as it is; a page below it would be a page no image has).
[[gnu::noinline]] void grow_stack(std::size_t bytes) {
  const std::uintptr_t sp = stack_pointer();
  for (std::uintptr_t a = page_down(sp); a > sp - bytes; a -= kPage) {
    (void)*reinterpret_cast<volatile const char*>(a);
  }
}

sys::SysResult<void> prepare_self() {
  if (self.standby_lo != 0) return {};  // prepared already
  // A sanitizer's allocator keeps the heap in regions of its own, outside the brk heap the layout covers (ASan
  // refuses mallopt; TSan accepts it and allocates elsewhere all the same): images by fork only.
  if (sys::kSanitizerBuild) return std::unexpected(sys::SysError{"prepare_self (sanitizer build)", ENOTSUP});
  // Every allocation in the brk heap, which the layout covers: no mmap for large blocks, no second arena,
  // no trimming (a heap that shrinks and grows again is a layout that changed), room to grow in steps.
  if (::mallopt(M_MMAP_MAX, 0) == 0 || ::mallopt(M_ARENA_MAX, 1) == 0 ||
      ::mallopt(M_TRIM_THRESHOLD, kHeapTopPad * 4) == 0 || ::mallopt(M_TOP_PAD, kHeapTopPad) == 0) {
    return std::unexpected(sys::SysError{"mallopt", EINVAL});
  }
  grow_stack(kStackReserve);
  if (auto maps = read_maps(); !maps) return maps;
  void* standby = ::mmap(nullptr, kStandbyStackBytes, PROT_READ | PROT_WRITE,
                         MAP_PRIVATE | MAP_ANONYMOUS | MAP_STACK, -1, 0);
  if (standby == MAP_FAILED) return sys::last_error("mmap(standby stack)");
  self.standby_lo = reinterpret_cast<std::uintptr_t>(standby);
  if (map_scratch() == nullptr) return sys::last_error("mmap(scratch)");
  return {};
}

bool whole_memory_tracked() { return scratch != nullptr && !self.other_writable; }

// This function's frame: a local's address would do as well, but clang warns on it, and under ASan a local
// may live on a fake stack elsewhere.
[[gnu::noinline]] std::uintptr_t stack_pointer() {
  return reinterpret_cast<std::uintptr_t>(__builtin_frame_address(0));
}

Layout layout_at(std::uintptr_t stack_pointer) {
  Layout now = whole_layout();
  now.stack.lo = page_down(stack_pointer - kStackMargin);
  return now;
}

void run_on_standby_stack(void (*fn)(int), int arg) {
  if (scratch == nullptr || self.standby_lo == 0) {
    // Not prepared (prepare_self failed, e.g. a sanitized build whose allocator refuses mallopt): on this
    // stack, below the caller's frames, which are what the image resumes into (resume_saved jumps up to
    // them). Such a process only ever takes its images by fork, which is all it needs.
    fn(arg);
    ::_exit(3);
  }
  scratch->standby_fn = fn;
  scratch->standby_arg = arg;
  ucontext_t& ctx = scratch->standby_context;
  if (::getcontext(&ctx) != 0) ::_exit(3);
  ctx.uc_stack.ss_sp = reinterpret_cast<void*>(self.standby_lo);
  ctx.uc_stack.ss_size = kStandbyStackBytes;
  ctx.uc_link = nullptr;
  ::makecontext(&ctx, standby_entry, 0);
  ::setcontext(&ctx);
  ::_exit(3);  // setcontext does not return on success
}

sys::SysResult<void> load_self(const Layout& layout, int image_fd) {
  if (check(layout) != nullptr || layout.data != self.data || layout.heap.lo != self.heap_lo ||
      layout.stack.hi != self.stack_hi) {
    return std::unexpected(sys::SysError{"load_self: not this executable's layout", EINVAL});
  }
  const long brk = ::syscall(SYS_brk, 0);
  if (static_cast<std::uintptr_t>(brk) < layout.heap.hi &&
      static_cast<std::uintptr_t>(::syscall(SYS_brk, layout.heap.hi)) < layout.heap.hi) {
    return std::unexpected(sys::SysError{"brk", ENOMEM});
  }
  // A fault below the stack mapping grows it (the image may have used more stack than this process).
  (void)*reinterpret_cast<volatile const char*>(layout.stack.lo);
  // From here on this process's data, heap and stack are the image's: raw system calls only, locals on the
  // standby stack only.
  off_t at = 0;
  for (const Region& r : {layout.data, layout.heap, layout.stack}) {
    std::size_t done = 0;
    while (done < r.size()) {
      const long n = ::syscall(SYS_pread64, image_fd, reinterpret_cast<void*>(r.lo + done), r.size() - done,
                               at + static_cast<off_t>(done));
      if (n <= 0) return std::unexpected(sys::SysError{"pread(image)", n == 0 ? EIO : EFAULT});
      done += static_cast<std::size_t>(n);
    }
    at += static_cast<off_t>(r.size());
  }
  if (tracks_writes_flag) return track_writes_self();  // the image's process tracked: from the image as loaded
  return {};
}

void resume_saved(Context& ctx) { __builtin_longjmp(ctx, 1); }

// ---- written pages ----

bool tracking_writes() { return scratch != nullptr && scratch->uffd >= 0; }

void forget_tracking() {
  if (scratch == nullptr) return;
  if (scratch->uffd >= 0) ::close(scratch->uffd);
  if (scratch->pagemap >= 0) ::close(scratch->pagemap);
  scratch->uffd = -1;
  scratch->pagemap = -1;
}

Layout tracked_layout() { return scratch != nullptr ? scratch->tracked : Layout{}; }

bool layout_unchanged(std::uintptr_t stack_pointer) {
  if (!tracking_writes()) return false;
  const Layout now = layout_at(stack_pointer);
  return now.heap == scratch->tracked.heap && now.stack.lo >= scratch->tracked.stack.lo;
}

sys::SysResult<void> track_writes_self() {
  forget_tracking();
  if (scratch == nullptr) return std::unexpected(sys::SysError{"track_writes_self: call prepare_self first", EINVAL});
  scratch->tracked = whole_layout();
  // User-mode faults only: what an unprivileged process may ask for (vm.unprivileged_userfaultfd = 0). The
  // asynchronous mode resolves every write fault, the kernel's own included, without a handler.
  int uffd = high_fd(static_cast<int>(::syscall(SYS_userfaultfd, O_CLOEXEC | O_NONBLOCK | kUffdUserModeOnly)));
  if (uffd < 0) uffd = high_fd(static_cast<int>(::syscall(SYS_userfaultfd, O_CLOEXEC | O_NONBLOCK)));
  if (uffd < 0) return sys::last_error("userfaultfd");
  scratch->uffd = uffd;
  uffdio_api api{.api = UFFD_API, .features = kUffdFeatureWpAsync | kUffdFeatureWpUnpopulated, .ioctls = 0};
  if (::ioctl(uffd, UFFDIO_API, &api) != 0) {
    forget_tracking();
    return sys::last_error("UFFDIO_API (WP_ASYNC)");
  }
  for (const Region& r : {scratch->tracked.data, scratch->tracked.heap, scratch->tracked.stack}) {
    if (r.size() == 0) continue;
    uffdio_register reg{.range = {.start = r.lo, .len = r.size()}, .mode = UFFDIO_REGISTER_MODE_WP, .ioctls = 0};
    uffdio_writeprotect wp{.range = {.start = r.lo, .len = r.size()}, .mode = UFFDIO_WRITEPROTECT_MODE_WP};
    if (::ioctl(uffd, UFFDIO_REGISTER, &reg) != 0 || ::ioctl(uffd, UFFDIO_WRITEPROTECT, &wp) != 0) {
      forget_tracking();
      return sys::last_error("UFFDIO_REGISTER/WRITEPROTECT");
    }
  }
  // A non-dumpable process of another uid than root cannot open its own pagemap: its kernel hands it one
  // (copy_written_self's `pagemap`).
  scratch->pagemap = no_more_opens ? -1 : high_fd(::open("/proc/self/pagemap", O_RDONLY | O_CLOEXEC));
  if (!tracks_writes_flag) tracks_writes_flag = true;
  return {};
}

void opens_done() { no_more_opens = true; }

sys::SysResult<std::size_t> copy_written_self(int fd, int pagemap) {
  if (!tracking_writes()) return std::unexpected(sys::SysError{"copy_written_self: not tracking", EINVAL});
  if (pagemap < 0) pagemap = scratch->pagemap;
  if (pagemap < 0) return std::unexpected(sys::SysError{"copy_written_self: no pagemap", EBADF});
  std::size_t n = 0;
  std::size_t iovs = 0;
  for (const Region& r : {scratch->tracked.data, scratch->tracked.heap, scratch->tracked.stack}) {
    if (r.size() == 0) continue;
    PmScanArg& arg = scratch->arg;
    arg = PmScanArg{.size = sizeof(PmScanArg), .flags = kScanWpMatching | kScanCheckWpAsync, .start = r.lo,
                  .end = r.hi, .walk_end = 0, .vec = reinterpret_cast<std::uint64_t>(scratch->scanned.data()),
                  .vec_len = scratch->scanned.size(), .max_pages = 0, .category_inverted = 0,
                  .category_mask = kPageIsWritten, .category_anyof_mask = 0, .return_mask = kPageIsWritten};
    const int got = ::ioctl(pagemap, kPagemapScan, &arg);
    if (got < 0) return sys::last_error("PAGEMAP_SCAN");
    if (arg.walk_end != r.hi) return std::unexpected(sys::SysError{"PAGEMAP_SCAN: more runs than fit", E2BIG});
    for (int i = 0; i < got; ++i) {
      const PageRegion& run = scratch->scanned[static_cast<std::size_t>(i)];
      if (iovs == scratch->pages.size()) return std::unexpected(sys::SysError{"copy_written_self: runs", E2BIG});
      scratch->pages[iovs++] = iovec{reinterpret_cast<void*>(run.start), run.end - run.start};
      for (std::uint64_t a = run.start; a < run.end; a += kPage) {
        if (n == scratch->addresses.size()) return std::unexpected(sys::SysError{"copy_written_self: pages", E2BIG});
        scratch->addresses[n++] = a;
      }
    }
  }
  scratch->written = n;
  if (fd < 0) return n;  // re-armed only
  const auto table = static_cast<ssize_t>(n * sizeof(std::uint64_t));
  if (::pwrite(fd, scratch->addresses.data(), static_cast<std::size_t>(table), 0) != table) return sys::last_error("pwrite");
  if (iovs > 0 && ::pwritev(fd, scratch->pages.data(), static_cast<int>(iovs), static_cast<off_t>(kWrittenPagesAt)) !=
                      static_cast<ssize_t>(n * kPage)) {
    return sys::last_error("pwritev");
  }
  return n;
}

sys::SysResult<void> apply_written(int fd, std::size_t pages) {
  if (scratch == nullptr || pages > kMaxWrittenPages) return std::unexpected(sys::SysError{"apply_written: pages", EINVAL});
  const auto table = static_cast<ssize_t>(pages * sizeof(std::uint64_t));
  if (::pread(fd, scratch->addresses.data(), static_cast<std::size_t>(table), 0) != table) {
    return sys::last_error("pread(page addresses)");
  }
  // Every page inside this process's data+bss, heap and stack: the same layout the pages were taken from
  // (a service takes an image by written pages only while its layout is the one its base image has).
  const Layout own = whole_layout();
  std::uintptr_t previous = 0;
  for (std::size_t i = 0; i < pages; ++i) {
    const std::uintptr_t a = scratch->addresses[i];
    if (a % kPage != 0 || (i > 0 && a <= previous) || !offset_in_image(own, a)) {
      return std::unexpected(sys::SysError{"apply_written: a page outside the image", EINVAL});
    }
    previous = a;
  }
  // From here on: raw system calls and standby-stack locals only (the pages land in data, heap and stack).
  std::size_t done = 0;
  while (done < pages) {
    std::size_t iovs = 0;
    std::size_t first = done;
    while (done < pages && iovs < scratch->pages.size()) {
      const std::uintptr_t a = scratch->addresses[done];
      if (iovs > 0 && reinterpret_cast<std::uintptr_t>(scratch->pages[iovs - 1].iov_base) +
                              scratch->pages[iovs - 1].iov_len == a) {
        scratch->pages[iovs - 1].iov_len += kPage;
      } else {
        scratch->pages[iovs++] = iovec{reinterpret_cast<void*>(a), kPage};
      }
      ++done;
    }
    const auto want = static_cast<long>((done - first) * kPage);
    const ssize_t n = ::preadv(fd, scratch->pages.data(), static_cast<int>(iovs),
                               static_cast<off_t>(kWrittenPagesAt + first * kPage));
    if (n != want) return std::unexpected(sys::SysError{"preadv(pages)", n < 0 ? EFAULT : EIO});
  }
  scratch->written = pages;
  return {};
}

sys::SysResult<sys::UniqueFd> make_record_file() {
  sys::UniqueFd fd(::memfd_create("rejuv-image-pages", MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (!fd.valid()) return sys::last_error("memfd_create");
  // Room for the address table's first page and for twice the pages the last image carried (at least
  // kRecordPagesAhead); a larger image allocates the rest inside copy_written_self. Best effort.
  const std::size_t last = scratch != nullptr ? scratch->written : 0;
  const std::size_t pages = std::clamp(2 * last, kRecordPagesAhead, 4 * kRecordPagesAhead);
  if (::fallocate(fd.get(), 0, 0, static_cast<off_t>(kPage)) == 0) {
    (void)::fallocate(fd.get(), 0, static_cast<off_t>(kWrittenPagesAt), static_cast<off_t>(pages * kPage));
  }
  return fd;
}

void touch_working_set() {
  if (scratch == nullptr) return;
  const Layout own = whole_layout();
  const std::size_t n = std::min(scratch->written, kMaxTouchedPages);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uintptr_t a = scratch->addresses[i];
    if (!offset_in_image(own, a)) continue;
    // The byte written back as read: the image's contents stay what they are, the page becomes this
    // process's own (copied from the one it shared since the fork) and writable.
    auto* byte = reinterpret_cast<volatile unsigned char*>(a);
    *byte = *byte;
  }
}

std::optional<std::size_t> offset_in_image(const Layout& layout, std::uintptr_t address) {
  std::size_t base = 0;
  for (const Region& r : {layout.data, layout.heap, layout.stack}) {
    if (address >= r.lo && address + kPage <= r.hi) return base + (address - r.lo);
    base += r.size();
  }
  return std::nullopt;
}

sys::SysResult<void> read_process(pid_t pid, const Layout& layout, std::span<std::byte> into) {
  if (const char* bad = check(layout); bad != nullptr) return std::unexpected(sys::SysError{bad, EINVAL});
  if (into.size() < layout.bytes()) return std::unexpected(sys::SysError{"read_process: buffer", ENOSPC});
  const std::array<iovec, 3> remote{iovec{reinterpret_cast<void*>(layout.data.lo), layout.data.size()},
                                    iovec{reinterpret_cast<void*>(layout.heap.lo), layout.heap.size()},
                                    iovec{reinterpret_cast<void*>(layout.stack.lo), layout.stack.size()}};
  const iovec local{into.data(), layout.bytes()};
  const ssize_t n = ::process_vm_readv(pid, &local, 1, remote.data(), remote.size(), 0);
  if (n < 0) return sys::last_error("process_vm_readv");
  if (static_cast<std::size_t>(n) != layout.bytes()) return std::unexpected(sys::SysError{"process_vm_readv: short", EFAULT});
  return {};
}

}  // namespace rejuv::memory_image
