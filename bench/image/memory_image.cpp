#include "memory_image.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <ucontext.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace rejuv::bench_image {

namespace {

constexpr std::uintptr_t kPage = 4096;
constexpr std::size_t kStandbyStackBytes = std::size_t{256} << 10;
// Below the saved stack pointer: the red zone and the frames of the calls the service makes after saving
// (they are scratch in the image, but copying a little more keeps the page that holds the pointer whole).
constexpr std::uintptr_t kStackMargin = 512;

std::uintptr_t page_down(std::uintptr_t a) { return a & ~(kPage - 1); }

// The fixed facts of this executable's address space, the same in every process forked from it. They live
// in .bss, so loading an image writes the same values over them.
struct Self {
  Region data;
  std::uintptr_t heap_lo = 0;
  std::uintptr_t stack_hi = 0;
  std::uintptr_t standby_lo = 0;
  void (*standby_fn)(int) = nullptr;
  int standby_arg = -1;
};
Self self;

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
      if (std::strcmp(path, "[heap]") == 0) self.heap_lo = lo;
      if (std::strcmp(path, "[stack]") == 0) self.stack_hi = hi;
    }
    line = next;
  }
  if (self.data.lo == 0 || self.stack_hi == 0) return std::unexpected(sys::SysError{"/proc/self/maps: no data or stack", ENOENT});
  if (self.heap_lo == 0) self.heap_lo = reinterpret_cast<std::uintptr_t>(::sbrk(0));  // no heap yet
  return {};
}

ucontext_t standby_context;

void standby_entry() { self.standby_fn(self.standby_arg); ::_exit(3); }

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

sys::SysResult<void> prepare_self() {
  if (self.standby_lo != 0) return {};  // prepared already
  // Every allocation in the brk heap, which the layout covers: no mmap for large blocks, no second arena.
  if (::mallopt(M_MMAP_MAX, 0) == 0 || ::mallopt(M_ARENA_MAX, 1) == 0) {
    return std::unexpected(sys::SysError{"mallopt", EINVAL});
  }
  if (auto maps = read_maps(); !maps) return maps;
  void* standby = ::mmap(nullptr, kStandbyStackBytes, PROT_READ | PROT_WRITE,
                         MAP_PRIVATE | MAP_ANONYMOUS | MAP_STACK, -1, 0);
  if (standby == MAP_FAILED) return sys::last_error("mmap(standby stack)");
  self.standby_lo = reinterpret_cast<std::uintptr_t>(standby);
  return {};
}

[[gnu::noinline]] std::uintptr_t stack_pointer() {
  volatile char here = 0;
  return reinterpret_cast<std::uintptr_t>(&here);
}

Layout layout_at(std::uintptr_t stack_pointer) {
  const auto brk = reinterpret_cast<std::uintptr_t>(::sbrk(0));
  return Layout{.data = self.data,
                .heap = Region{self.heap_lo, (brk + kPage - 1) & ~(kPage - 1)},
                .stack = Region{page_down(stack_pointer - kStackMargin), self.stack_hi}};
}

void run_on_standby_stack(void (*fn)(int), int arg) {
  self.standby_fn = fn;
  self.standby_arg = arg;
  if (::getcontext(&standby_context) != 0) ::_exit(3);
  standby_context.uc_stack.ss_sp = reinterpret_cast<void*>(self.standby_lo);
  standby_context.uc_stack.ss_size = kStandbyStackBytes;
  standby_context.uc_link = nullptr;
  ::makecontext(&standby_context, standby_entry, 0);
  ::setcontext(&standby_context);
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
  return {};
}

void resume_saved(Context& ctx) { __builtin_longjmp(ctx, 1); }

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

}  // namespace rejuv::bench_image
