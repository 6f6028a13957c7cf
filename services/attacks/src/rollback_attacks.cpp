// The attacks on rollback itself (idl/launch.proto AttackKind 18…27; docs/sandbox.md "Threats that used
// rollback itself"): what a compromised service can try, with calls a service may make or once could, so
// that the next rollback (§IV-B: the restore of a clean image) fails or stalls — by signalling its own frozen images
// or the kernel through SIGIO, by leaving a trap on an open file that a restored incarnation shares, by
// spawning processes and threads for the kernel to clean up, by acting after its incarnation was retired.
// docs/sandbox.md gives, for each, the defence that stops it; tests/security/rollback_attack_test.cpp flies
// each against the square, in real time and in lockstep, and judges it by its effect.
//
// Like hooks.cpp, the attacker's calls are made here directly (this is the code of a compromised service);
// a process or thread made here runs only system calls and plain loops (the C library's locks, the
// allocator and the channel belong to the service).
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <string>

#include "rejuv/attacks/hooks.hpp"
#include "rejuv/channel/wire.hpp"

namespace rejuv::attacks {

namespace {

constexpr std::uint32_t kDefaultSpinners = 40;
constexpr std::uint32_t kDefaultMemoryStrays = 6;
constexpr std::uint32_t kDefaultThreads = 40;
constexpr std::size_t kStrayMemory = std::size_t{512} << 20U;  // bytes each STRAY_MEMORY process touches
constexpr std::size_t kThreadStack = std::size_t{64} << 10U;    // small stacks: 40 threads fit any RLIMIT_AS
constexpr std::uint32_t kDefaultOomMb = 600;  // OOM_IMAGES: MiB touched at boot (1.5× that in each window)

std::int64_t outcome(long rc) { return rc >= 0 ? 0 : errno; }

[[noreturn]] void spin_forever() {
  for (;;) {
    asm volatile("" ::: "memory");  // a busy loop the compiler keeps
  }
}

// A process made like an image (the only flags the filter lets a service clone a process with): the kernel's
// child, in the service's session. Returns the child's pid (or −1) in the parent; the child runs `body`.
template <class Body>
long stray(Body body) {
  const long pid = ::syscall(SYS_clone, CLONE_PARENT | SIGCHLD, 0, 0, 0, 0);
  if (pid == 0) body();
  return pid;
}

[[noreturn]] void touch_and_spin() {
  const long addr = ::syscall(SYS_mmap, nullptr, kStrayMemory, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS,
                              -1, 0);
  if (addr > 0) {
    auto* p = reinterpret_cast<volatile char*>(addr);  // NOLINT: the mapping just made
    for (std::size_t off = 0; off < kStrayMemory; off += 4096) p[off] = 1;  // NOLINT: inside the mapping
  }
  spin_forever();
}

void* spin_thread(void* /*unused*/) { spin_forever(); }

// Starts a detached thread with a small stack; false when the C library or the sandbox refused it.
bool start_thread(void* (*fn)(void*), void* arg) {
  pthread_attr_t attr;
  if (::pthread_attr_init(&attr) != 0) return false;
  (void)::pthread_attr_setstacksize(&attr, kThreadStack);
  (void)::pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
  pthread_t t{};
  const bool ok = ::pthread_create(&t, &attr, fn, arg) == 0;
  (void)::pthread_attr_destroy(&attr);
  return ok;
}

// RETIRED_WORKER's thread: waits (on the time page, no call) until the rollback epoch changes, which means
// its incarnation was retired by a rollback, and then writes what would ruin a restored incarnation sharing
// its open files: garbage frames on the channel, lines on the log, forever.
struct RetiredWorker {
  const sdk::Service* svc;
  std::uint32_t epoch;
};

void* retired_worker(void* arg) {
  const RetiredWorker w = *static_cast<RetiredWorker*>(arg);
  delete static_cast<RetiredWorker*>(arg);  // NOLINT(cppcoreguidelines-owning-memory): made by its starter
  while (static_cast<std::uint32_t>(w.svc->epoch().value()) == w.epoch) {
    timespec pause{.tv_sec = 0, .tv_nsec = 100'000};
    (void)::syscall(SYS_nanosleep, &pause, nullptr);
  }
  std::array<std::byte, 64> garbage{};
  garbage.fill(std::byte{0xEE});
  static constexpr char kLine[] = "RETIRED-WORKER still running after the rollback\n";
  for (;;) {
    (void)::syscall(SYS_write, wire::kChannelFd, garbage.data(), garbage.size());
    (void)::syscall(SYS_write, 1, kLine, sizeof kLine - 1);
  }
}

void* raise_urg(void* done) {
  static_cast<std::atomic<int>*>(done)->store(::raise(SIGURG) == 0 ? 1 : 2 + errno);
  return nullptr;
}

}  // namespace

void AttackHooks::sigio(AttackKind kind, int fd, long owner, int signal) {
  svc_.logf(sdk::LogLevel::Warn, "attack %s: fcntl(%d, F_SETOWN, %ld), F_SETSIG %s, O_ASYNC",
            std::string(to_string(kind)).c_str(), fd, owner, ::sigabbrev_np(signal));
  (void)svc_.flush();  // said first: the first forbidden call ends this process
  report(kind, "fcntl(F_SETOWN)", static_cast<std::uint64_t>(owner), outcome(::fcntl(fd, F_SETOWN, owner)));
  report(kind, "fcntl(F_SETSIG)", static_cast<std::uint64_t>(signal), outcome(::fcntl(fd, F_SETSIG, signal)));
  const int flags = ::fcntl(fd, F_GETFL);
  report(kind, "fcntl(F_SETFL, O_ASYNC)", static_cast<std::uint64_t>(fd),
         outcome(::fcntl(fd, F_SETFL, (flags < 0 ? 0 : flags) | O_ASYNC)));
}

void AttackHooks::against_rollback(AttackKind kind, std::uint32_t variant, std::uint32_t count) {
  // The ones that signal or spawn: never outside a seccomp filter (a hook run outside the kernel must not
  // signal anyone nor leave a process behind).
  const bool needs_sandbox = kind == AttackKind::StraySpinners || kind == AttackKind::StrayMemory ||
                             kind == AttackKind::OomImages ||
                             kind == AttackKind::SigioImages || kind == AttackKind::SigioKernel ||
                             kind == AttackKind::SigioLogTrap;
  if (needs_sandbox && !under_filter_) {
    svc_.logf(sdk::LogLevel::Warn, "attack %s skipped: not under a seccomp filter", std::string(to_string(kind)).c_str());
    return;
  }
  switch (kind) {
    case AttackKind::SigioImages:
      sigio(kind, wire::kChannelFd, -pgrp_, variant % 2 == 0 ? SIGSTOP : SIGUSR1);
      break;
    case AttackKind::SigioKernel: sigio(kind, wire::kChannelFd, static_cast<long>(::getppid()), SIGKILL); break;
    case AttackKind::SigioLogTrap: sigio(kind, 1, -pgrp_, SIGUSR1); break;
    case AttackKind::StraySpinners:
    case AttackKind::StrayMemory: strays(kind, count); break;
    case AttackKind::SpinningThreads: {
      const std::uint32_t n = count != 0 ? count : kDefaultThreads;
      std::uint32_t made = 0;
      for (std::uint32_t i = 0; i < n; ++i) made += start_thread(spin_thread, nullptr) ? 1U : 0U;
      report(kind, "pthread_create x" + std::to_string(n), made, made == n ? 0 : EAGAIN);
      svc_.logf(sdk::LogLevel::Warn, "attack SPINNING_THREADS: %u of %u threads spinning", made, n);
      break;
    }
    case AttackKind::RetiredWorker: {
      auto* w = new RetiredWorker{&svc_, static_cast<std::uint32_t>(svc_.epoch().value())};  // NOLINT: the thread's
      const bool ok = start_thread(retired_worker, w);
      if (!ok) delete w;  // NOLINT(cppcoreguidelines-owning-memory)
      report(kind, "pthread_create", 1, ok ? 0 : EAGAIN);
      break;
    }
    case AttackKind::WorkerRaise: {
      std::atomic<int> done{0};
      pthread_t t{};
      if (::pthread_create(&t, nullptr, raise_urg, &done) == 0) (void)::pthread_join(t, nullptr);
      report(kind, "raise(SIGURG) in a thread", 0, done.load() == 1 ? 0 : done.load());
      break;
    }
    case AttackKind::ForgedLog:
      // One Log frame: a line that ends at once, then a kernel line of its own, a carriage return over it,
      // a screen clear and an OSC title (what a terminal would obey).
      svc_.log(sdk::LogLevel::Warn,
               "ok\n[kernel 99.999] rollback to generation 7 FORGED-BY-SERVICE\r\x1b[2J\x1b]0;owned\x07 end");
      report(kind, "Log", 0, Attempt::kFireAndForget);
      break;
    case AttackKind::PagemapFrames: pagemap_frames(); break;
    case AttackKind::OomImages: oom_images(variant, count); break;
    case AttackKind::InvokeCheckpoint:  // the attacks on the runtime's interface: hooks.cpp
    case AttackKind::ArmTimer:
    case AttackKind::WriteLimits:
    case AttackKind::PublishActuatorOutputs:
    case AttackKind::WritePersistent:
    case AttackKind::ForgedSlot:
    case AttackKind::NetworkInSei:
    case AttackKind::KillImage:
    case AttackKind::OpenSocket:
    case AttackKind::FloodBroker:
    case AttackKind::EscapeHelper:
    case AttackKind::BootTimePage:  // a binary hostile from boot: boot_attacks.cpp
    case AttackKind::BootPrlimitKernel:
    case AttackKind::BootReadSecrets: break;
  }
}

void AttackHooks::strays(AttackKind kind, std::uint32_t count) {
  const bool memory = kind == AttackKind::StrayMemory;
  const std::uint32_t n = count != 0 ? count : (memory ? kDefaultMemoryStrays : kDefaultSpinners);
  std::uint32_t made = 0;
  int last_errno = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const long pid = memory ? stray(touch_and_spin) : stray(spin_forever);
    if (pid > 0) {
      ++made;
    } else {
      last_errno = errno;
    }
  }
  report(kind, "clone(CLONE_PARENT|SIGCHLD) x" + std::to_string(n), made, made == n ? 0 : last_errno);
  svc_.logf(sdk::LogLevel::Warn, "attack %s: %u of %u strays made", std::string(to_string(kind)).c_str(), made, n);
}

void AttackHooks::oom_images(std::uint32_t variant, std::uint32_t count) {
  // At boot: m MiB touched, which every image then maps (their pages are charged to the service's memory
  // cgroup where they were first touched). In each window: its own copy unmapped — the images keep the
  // pages, so nothing is given back — and 1.5·m MiB touched afresh. Where one memory cgroup held the live
  // incarnation and its images, its OOM killer killed the largest process: an image.
  const bool at_boot = variant == kAtBoot;
  const std::size_t mb = (count != 0 ? count : kDefaultOomMb) * (at_boot ? 2U : 3U) / 2U;
  const std::size_t bytes = mb << 20U;
  svc_.logf(sdk::LogLevel::Warn, "attack OOM_IMAGES: %s, touching %zu MiB", at_boot ? "at boot" : "its copy unmapped", mb);
  (void)svc_.flush();  // said first: the touch may end this process
  if (!at_boot && oom_mapping_ != nullptr) (void)::syscall(SYS_munmap, oom_mapping_, oom_bytes_);
  oom_mapping_ = nullptr;
  const long addr = ::syscall(SYS_mmap, nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (addr == -1) {
    report(AttackKind::OomImages, "mmap " + std::to_string(mb) + " MiB", mb, errno);
    return;
  }
  auto* p = reinterpret_cast<volatile char*>(addr);  // NOLINT: the mapping just made
  for (std::size_t off = 0; off < bytes; off += 4096) p[off] = 1;  // NOLINT: inside the mapping
  oom_mapping_ = reinterpret_cast<void*>(addr);  // NOLINT: the mapping just made
  oom_bytes_ = bytes;
  report(AttackKind::OomImages, "touch " + std::to_string(mb) + " MiB", mb, 0);
  svc_.logf(sdk::LogLevel::Warn, "attack OOM_IMAGES: %zu MiB touched and kept", mb);
}

void AttackHooks::pagemap_frames() {
  // The pagemap is the fd whose 8-byte entries for pages this process surely has (its stack, this code, its
  // heap) all say "present" (bit 63). Physical frame numbers are bits 0…54.
  std::array<std::uintptr_t, 3> pages{reinterpret_cast<std::uintptr_t>(&pages),                  // NOLINT
                                      reinterpret_cast<std::uintptr_t>(&spin_forever),            // NOLINT
                                      reinterpret_cast<std::uintptr_t>(plan_.attacks.data())};  // NOLINT
  constexpr std::uint64_t kPresent = 1ULL << 63U;
  constexpr std::uint64_t kFrameMask = (1ULL << 55U) - 1;
  int found = -1;
  std::uint32_t present = 0;
  std::uint32_t frames = 0;
  for (int fd = 5; fd < 1024 && found < 0; ++fd) {
    if (::fcntl(fd, F_GETFD) < 0) continue;
    std::uint32_t p = 0;
    std::uint32_t f = 0;
    for (const std::uintptr_t a : pages) {
      std::uint64_t entry = 0;
      if (::pread(fd, &entry, sizeof entry, static_cast<off_t>((a / 4096) * sizeof entry)) != sizeof entry) break;
      if ((entry & kPresent) == 0) break;
      ++p;
      if ((entry & kFrameMask) != 0) ++f;
    }
    if (p == pages.size()) {
      found = fd;
      present = p;
      frames = f;
    }
  }
  svc_.logf(sdk::LogLevel::Warn, "attack PAGEMAP_FRAMES: pagemap fd %d, %u pages present, %u frame numbers seen",
            found, present, frames);
  report(AttackKind::PagemapFrames, "pread(pagemap)", static_cast<std::uint64_t>(frames), found < 0 ? ENOENT : 0);
}

}  // namespace rejuv::attacks
