// A service binary hostile from its first instruction (idl/launch.proto AttackKind 29…31;
// docs/sandbox.md "No trusted boot phase"): what it tries before it says Ready, while the kernel still lets
// boot calls (open, prlimit64, prctl …) through. Carried out by install() before svc.run() — the service's
// code is not trusted from the start (docs/design.md §7), so rollback to a clean image cannot help: the kernel's own
// state and the user's secrets must be out of reach from the first call. Each step says what it achieved in
// one log line (`attack KIND: …`), which tests/security/rollback_attack_test.cpp reads.
//
// Like hooks.cpp, the attacker's calls are made here directly (this is the code of a compromised service).
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <string>

#include "rejuv/attacks/hooks.hpp"
#include "rejuv/channel/wire.hpp"

namespace rejuv::attacks {

namespace {

std::int64_t outcome(long rc) { return rc >= 0 ? 0 : errno; }

// Up to `limit` bytes of `path` with raw calls, or the errno of the first that failed (as a negative number
// in `err`).
std::string slurp(const std::string& path, std::size_t limit, int& err) {
  err = 0;
  const int fd = static_cast<int>(::syscall(SYS_openat, AT_FDCWD, path.c_str(), O_RDONLY | O_CLOEXEC, 0));
  if (fd < 0) {
    err = errno;
    return {};
  }
  std::string out;
  std::array<char, 4096> buf{};
  while (out.size() < limit) {
    const long n = ::syscall(SYS_read, fd, buf.data(), buf.size());
    if (n <= 0) {
      if (n < 0) err = errno;
      break;
    }
    out.append(buf.data(), static_cast<std::size_t>(n));
  }
  ::syscall(SYS_close, fd);
  return out;
}

// The quoted value after `key` in a text-format file ("signing_key_file: \"k.hex\"" → k.hex), or "".
std::string quoted_after(const std::string& text, const std::string& key) {
  const std::size_t at = text.find(key);
  if (at == std::string::npos) return {};
  const std::size_t open = text.find('"', at + key.size());
  const std::size_t close = open == std::string::npos ? open : text.find('"', open + 1);
  if (close == std::string::npos) return {};
  return text.substr(open + 1, close - open - 1);
}

// Only printable characters of `bytes` (the key file holds hex digits; anything else shows as '.').
std::string printable(const std::string& bytes, std::size_t limit) {
  std::string out;
  for (std::size_t i = 0; i < bytes.size() && i < limit; ++i) {
    const char c = bytes[i];
    out += (c >= 0x21 && c < 0x7f) ? c : '.';
  }
  return out;
}

}  // namespace

void AttackHooks::hostile_from_boot(AttackKind kind, std::uint32_t variant) {
  if (kind == AttackKind::BootTimePage) {
    time_page_write(variant == kAtBoot);
  } else if (kind == AttackKind::BootReadSecrets) {
    read_secrets();
  } else if (kind == AttackKind::BootPrlimitKernel) {
    if (!under_filter_) {  // outside the kernel's sandbox the parent is a test process: leave it alone
      svc_.log(sdk::LogLevel::Warn, "attack BOOT_PRLIMIT_KERNEL skipped: not under a seccomp filter");
      return;
    }
    const long kernel = static_cast<long>(::getppid());
    const rlimit one_second{1, 1};
    const long rc = ::syscall(SYS_prlimit64, kernel, RLIMIT_CPU, &one_second, nullptr);
    const std::int64_t code = outcome(rc);
    report(kind, "prlimit64(kernel, RLIMIT_CPU, {1, 1})", static_cast<std::uint64_t>(kernel), code);
    svc_.logf(sdk::LogLevel::Warn, "attack BOOT_PRLIMIT_KERNEL: prlimit64(%ld, RLIMIT_CPU, {1, 1}) = %s", kernel,
              code == 0 ? "0 (the kernel's CPU limit set)" : ("errno " + std::to_string(code)).c_str());
  }
}

// At boot: a writable handle on the kernel's time page, by the magic link (O_RDWR reopen of fd 4) and by a
// shared writable mapping of either fd. In each MC window: an odd sequence written through whichever worked
// (the reader's seqlock would spin for as long as the page stays odd).
void AttackHooks::time_page_write(bool at_boot) {
  constexpr int kTimePage = wire::kTimePageFd;
  if (at_boot) {
    const long fd = ::syscall(SYS_openat, AT_FDCWD, "/proc/self/fd/4", O_RDWR | O_CLOEXEC, 0);
    const std::int64_t open_code = outcome(fd);
    report(AttackKind::BootTimePage, "open(/proc/self/fd/4, O_RDWR)", 0, open_code);
    if (fd >= 0) time_page_writable_ = static_cast<int>(fd);
    for (const int candidate : {kTimePage, time_page_writable_}) {
      if (candidate < 0 || time_page_mapping_ != nullptr) continue;
      const long addr = ::syscall(SYS_mmap, nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED, candidate, 0);
      report(AttackKind::BootTimePage, "mmap(time page, PROT_WRITE, MAP_SHARED)", static_cast<std::uint64_t>(candidate),
             addr == -1 ? errno : 0);
      if (addr != -1) time_page_mapping_ = reinterpret_cast<void*>(addr);  // NOLINT: the mapping just made
    }
    svc_.logf(sdk::LogLevel::Warn, "attack BOOT_TIME_PAGE: at boot writable fd %s, writable mapping %s",
              time_page_writable_ >= 0 ? "obtained" : ("refused (errno " + std::to_string(open_code) + ")").c_str(),
              time_page_mapping_ != nullptr ? "obtained" : "refused");
    return;
  }
  // In MC: an odd sequence (the page's first 8 bytes: wire::TimePage::sequence).
  const std::uint64_t odd = 0x0DD0DD0DD0DD0DD1ULL;
  long written = -1;
  int write_errno = 0;
  for (const int fd : {time_page_writable_, kTimePage}) {
    if (fd < 0) continue;
    written = ::syscall(SYS_pwrite64, fd, &odd, sizeof(odd), 0);
    if (written == static_cast<long>(sizeof(odd))) break;
    write_errno = errno;
  }
  report(AttackKind::BootTimePage, "pwrite(time page, odd sequence)", 0, written == static_cast<long>(sizeof(odd)) ? 0 : write_errno);
  bool stored = false;
  if (time_page_mapping_ != nullptr) {
    static_cast<std::atomic<std::uint64_t>*>(time_page_mapping_)->store(odd, std::memory_order_release);
    stored = true;
  }
  svc_.logf(sdk::LogLevel::Warn, "attack BOOT_TIME_PAGE: odd sequence %s by pwrite (errno %d), %s by the mapping",
            written == static_cast<long>(sizeof(odd)) ? "written" : "refused", write_errno,
            stored ? "stored" : "not stored");
}

// At boot: the kernel's command line names the launch file; the launch file names the signing key's file,
// relative to itself; read both, and show what was read (a real attacker would exfiltrate it later).
void AttackHooks::read_secrets() {
  const long kernel = static_cast<long>(::getppid());
  int err = 0;
  std::string cmdline = slurp("/proc/" + std::to_string(kernel) + "/cmdline", 1 << 16, err);
  report(AttackKind::BootReadSecrets, "read /proc/<kernel>/cmdline", static_cast<std::uint64_t>(kernel), err);
  std::string launch;
  for (std::size_t at = 0; at < cmdline.size();) {
    const std::size_t end = cmdline.find('\0', at);
    const std::string arg = cmdline.substr(at, end == std::string::npos ? std::string::npos : end - at);
    if (arg.ends_with(".pbtxt")) launch = arg;
    if (end == std::string::npos) break;
    at = end + 1;
  }
  std::string key_path;
  if (!launch.empty()) {
    const std::string text = slurp(launch, 1 << 20, err);
    report(AttackKind::BootReadSecrets, "read the launch file", 0, err);
    if (const std::string named = quoted_after(text, "signing_key_file"); !named.empty()) {
      key_path = named.front() == '/' ? named : launch.substr(0, launch.rfind('/') + 1) + named;
    }
  }
  std::string key;
  int key_err = ENOENT;
  if (!key_path.empty()) key = slurp(key_path, 256, key_err);
  report(AttackKind::BootReadSecrets, "read the signing key file", 0, key_err);
  svc_.logf(sdk::LogLevel::Warn,
            "attack BOOT_READ_SECRETS: kernel cmdline %s (%zu bytes), key file '%s' %s: '%s'",
            cmdline.empty() ? "unread" : "read", cmdline.size(), key_path.c_str(),
            key_err == 0 ? "READ" : ("refused (errno " + std::to_string(key_err) + ")").c_str(),
            printable(key, 128).c_str());
}

}  // namespace rejuv::attacks
