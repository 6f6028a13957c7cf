// The hostile-service suite's escapes (escapes.hpp). Raw system calls where the C library would make a
// different call than the one named (fork() is clone with other flags, setrlimit is prlimit64), so that the
// test knows which call name the kernel must count.
#include "escapes.hpp"

#include <arpa/inet.h>
#include <elf.h>
#include <fcntl.h>
#include <linux/io_uring.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/ptrace.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <functional>
#include <map>
#include <vector>

#include "rejuv/channel/wire.hpp"

namespace rejuv::test_services::escapes {

namespace {

double rc_of(long rc) { return rc < 0 ? -static_cast<double>(errno) : static_cast<double>(rc); }

[[noreturn]] void sleep_forever() {
  for (;;) {
    timespec t{3600, 0};
    (void)::nanosleep(&t, nullptr);
  }
}

// The image fork's flags: allowed by the filter, the child is the kernel's (CLONE_PARENT).
long clone_parent() { return ::syscall(SYS_clone, CLONE_PARENT | SIGCHLD, nullptr, nullptr, nullptr, nullptr); }

sockaddr_in loopback(std::uint16_t port) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return to;
}

// A datagram to the test's listener from `fd` (0 bytes sent when the send fails).
long send_datagram(int fd, std::uint16_t port) {
  const sockaddr_in to = loopback(port);
  static constexpr char kMsg[] = "escaped";
  return ::sendto(fd, kMsg, sizeof kMsg, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);  // NOLINT
}

Outcome udp_send(const Target& t) {
  const long fd = ::syscall(SYS_socket, AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return {rc_of(fd), 0};
  return {rc_of(send_datagram(static_cast<int>(fd), t.udp_port)), static_cast<double>(fd)};
}

// io_uring_setup, then (if a ring is made) a socket by IORING_OP_SOCKET and a datagram from it: the socket
// would never pass through the socket() entry of the filter.
Outcome io_uring_socket(const Target& t) {
  io_uring_params p{};
  const long ring = ::syscall(SYS_io_uring_setup, 4, &p);
  if (ring < 0) return {rc_of(ring), 0};
  const int fd = static_cast<int>(ring);
  const std::size_t sq_size = p.sq_off.array + p.sq_entries * sizeof(std::uint32_t);
  const std::size_t cq_size = p.cq_off.cqes + p.cq_entries * sizeof(io_uring_cqe);
  auto* sq = static_cast<std::byte*>(::mmap(nullptr, sq_size, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, fd,
                                            IORING_OFF_SQ_RING));
  auto* cq = static_cast<std::byte*>(::mmap(nullptr, cq_size, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, fd,
                                            IORING_OFF_CQ_RING));
  auto* sqes = static_cast<io_uring_sqe*>(::mmap(nullptr, p.sq_entries * sizeof(io_uring_sqe), PROT_READ | PROT_WRITE,
                                                 MAP_SHARED | MAP_POPULATE, fd, IORING_OFF_SQES));
  if (sq == MAP_FAILED || cq == MAP_FAILED || sqes == MAP_FAILED) return {-static_cast<double>(errno), 1};
  std::memset(&sqes[0], 0, sizeof(io_uring_sqe));
  sqes[0].opcode = IORING_OP_SOCKET;
  sqes[0].fd = AF_INET;
  sqes[0].off = SOCK_DGRAM;
  auto* tail = reinterpret_cast<std::uint32_t*>(sq + p.sq_off.tail);  // NOLINT: the ring's layout
  const auto mask = *reinterpret_cast<std::uint32_t*>(sq + p.sq_off.ring_mask);  // NOLINT
  auto* array = reinterpret_cast<std::uint32_t*>(sq + p.sq_off.array);  // NOLINT
  array[*tail & mask] = 0;
  __atomic_store_n(tail, *tail + 1, __ATOMIC_RELEASE);
  const long entered = ::syscall(SYS_io_uring_enter, fd, 1, 1, IORING_ENTER_GETEVENTS, nullptr, 0);
  if (entered < 0) return {rc_of(entered), 2};
  const auto head = __atomic_load_n(reinterpret_cast<std::uint32_t*>(cq + p.cq_off.head), __ATOMIC_ACQUIRE);  // NOLINT
  const auto cq_mask = *reinterpret_cast<std::uint32_t*>(cq + p.cq_off.ring_mask);  // NOLINT
  const auto* cqes = reinterpret_cast<const io_uring_cqe*>(cq + p.cq_off.cqes);  // NOLINT
  const int socket_fd = cqes[head & cq_mask].res;
  if (socket_fd < 0) return {static_cast<double>(socket_fd), 3};
  return {rc_of(send_datagram(socket_fd, t.udp_port)), 4};
}

Outcome open_path(const char* path) {
  const long fd = ::syscall(SYS_openat, AT_FDCWD, path, O_RDONLY | O_CLOEXEC, 0);
  if (fd < 0) return {rc_of(fd), 0};
  std::array<char, 256> buf{};
  const long n = ::read(static_cast<int>(fd), buf.data(), buf.size());
  return {static_cast<double>(fd), rc_of(n)};  // detail: bytes read
}

Outcome create_file(const Target& t) {
  const long fd = ::syscall(SYS_openat, AT_FDCWD, t.path.c_str(), O_CREAT | O_WRONLY | O_CLOEXEC, 0666);
  if (fd < 0) return {rc_of(fd), 0};
  static constexpr char kMsg[] = "escaped\n";
  return {static_cast<double>(fd), rc_of(::write(static_cast<int>(fd), kMsg, sizeof kMsg - 1))};
}

// A static x86-64 ELF of one segment whose code is exit(42).
std::vector<unsigned char> exit42_elf() {
  constexpr std::uint64_t kBase = 0x400000;
  constexpr std::array<unsigned char, 12> kCode{0xbf, 42, 0, 0, 0,         // mov edi, 42
                                                0xb8, 60, 0, 0, 0,         // mov eax, SYS_exit
                                                0x0f, 0x05};               // syscall
  Elf64_Ehdr eh{};
  std::memcpy(eh.e_ident, ELFMAG, SELFMAG);
  eh.e_ident[EI_CLASS] = ELFCLASS64;
  eh.e_ident[EI_DATA] = ELFDATA2LSB;
  eh.e_ident[EI_VERSION] = EV_CURRENT;
  eh.e_type = ET_EXEC;
  eh.e_machine = EM_X86_64;
  eh.e_version = EV_CURRENT;
  eh.e_entry = kBase + sizeof(Elf64_Ehdr) + sizeof(Elf64_Phdr);
  eh.e_phoff = sizeof(Elf64_Ehdr);
  eh.e_ehsize = sizeof(Elf64_Ehdr);
  eh.e_phentsize = sizeof(Elf64_Phdr);
  eh.e_phnum = 1;
  Elf64_Phdr ph{};
  ph.p_type = PT_LOAD;
  ph.p_flags = PF_R | PF_X;
  ph.p_vaddr = ph.p_paddr = kBase;
  ph.p_filesz = ph.p_memsz = sizeof(Elf64_Ehdr) + sizeof(Elf64_Phdr) + kCode.size();
  ph.p_align = 0x1000;
  std::vector<unsigned char> out(sizeof eh + sizeof ph + kCode.size());
  std::memcpy(out.data(), &eh, sizeof eh);
  std::memcpy(out.data() + sizeof eh, &ph, sizeof ph);
  std::memcpy(out.data() + sizeof eh + sizeof ph, kCode.data(), kCode.size());
  return out;
}

Outcome memfd_exec() {
  const long fd = ::syscall(SYS_memfd_create, "escape", 0U);
  if (fd < 0) return {rc_of(fd), 0};
  const auto elf = exit42_elf();
  if (::write(static_cast<int>(fd), elf.data(), elf.size()) != static_cast<ssize_t>(elf.size())) return {-static_cast<double>(errno), 1};
  std::array<char*, 2> argv{const_cast<char*>("escape"), nullptr};  // NOLINT: execve's signature
  std::array<char*, 1> envp{nullptr};
  // fexecve(fd) is this call: execveat(fd, "", …, AT_EMPTY_PATH).
  return {rc_of(::syscall(SYS_execveat, fd, "", argv.data(), envp.data(), AT_EMPTY_PATH)), 2};
}

Outcome exec_sh() {
  std::array<char*, 4> argv{const_cast<char*>("sh"), const_cast<char*>("-c"),  // NOLINT
                            const_cast<char*>("echo escaped"), nullptr};        // NOLINT
  std::array<char*, 1> envp{nullptr};
  return {rc_of(::syscall(SYS_execve, "/bin/sh", argv.data(), envp.data())), 0};
}

Outcome mmap_rwx() {
  void* p = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE | PROT_EXEC, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  return {p == MAP_FAILED ? -static_cast<double>(errno) : 0.0, 0};
}

Outcome mprotect_exec() {
  void* p = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) return {-static_cast<double>(errno), 1};
  static_cast<unsigned char*>(p)[0] = 0xc3;  // ret
  return {rc_of(::mprotect(p, 4096, PROT_READ | PROT_EXEC)), 0};
}

Outcome vm_access(const Target& t, bool write) {
  std::uint64_t value = 0xBADC0FFEE0DDF00DULL;
  iovec local{&value, sizeof value};
  iovec remote{reinterpret_cast<void*>(t.address), sizeof value};  // NOLINT: an address in the kernel
  const pid_t kernel = ::getppid();
  const long n = write ? ::syscall(SYS_process_vm_writev, kernel, &local, 1, &remote, 1, 0)
                       : ::syscall(SYS_process_vm_readv, kernel, &local, 1, &remote, 1, 0);
  return {rc_of(n), static_cast<double>(value & 0xFFFF)};
}

// A helper the kernel does not know: the image fork's flags, so the clone itself is allowed.
Outcome helper() {
  const long pid = clone_parent();
  if (pid == 0) sleep_forever();
  return {rc_of(pid), static_cast<double>(pid)};
}

// A helper in a session of its own, where a sweep of the service's session would not find it.
Outcome helper_setsid() {
  const long pid = clone_parent();
  if (pid == 0) {
    if (::syscall(SYS_setsid) >= 0) sleep_forever();
    ::_exit(1);
  }
  return {rc_of(pid), static_cast<double>(pid)};
}

Outcome fork_bomb() {
  constexpr int kMax = 100;
  int made = 0;
  double first_error = 0;
  for (int i = 0; i < kMax; ++i) {
    const long pid = clone_parent();
    if (pid == 0) sleep_forever();
    if (pid < 0) {
      first_error = -static_cast<double>(errno);
      break;
    }
    ++made;
  }
  return {static_cast<double>(made), first_error};
}

Outcome fake_log() {
  // Lines that look like the kernel's: plain, after a carriage return, after an escape sequence, after an
  // early newline, and at the 1024-byte cut of an overlong line.
  std::string text = "[kernel    1.000] FAKE-KERNEL-LINE plain\n";
  text += "innocent\r[kernel    1.000] FAKE-KERNEL-LINE after-cr\n";
  text += "\x1b[2K\r[kernel    1.000] FAKE-KERNEL-LINE after-escape\n";
  text += "partial\n[kernel    1.000] FAKE-KERNEL-LINE after-newline\n";
  text += std::string(1024, 'x') + "[kernel    1.000] FAKE-KERNEL-LINE at-the-cut\n";
  long written = 0;
  for (const int fd : {1, 2}) written += ::write(fd, text.data(), text.size());
  return {static_cast<double>(written), 0};
}

Outcome memory_hog(const Target& t) {
  const std::size_t bytes = std::size_t{t.hog_mb} << 20U;
  void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_POPULATE, -1, 0);
  if (p == MAP_FAILED) return {-static_cast<double>(errno), static_cast<double>(t.hog_mb)};
  ::munmap(p, bytes);
  return {0, static_cast<double>(t.hog_mb)};
}

Outcome raise_rlimit() {
  const rlimit unlimited{RLIM_INFINITY, RLIM_INFINITY};
  const long as = ::syscall(SYS_prlimit64, 0, RLIMIT_AS, &unlimited, nullptr);
  const double as_rc = rc_of(as);
  const long nofile = ::syscall(SYS_prlimit64, 0, RLIMIT_NOFILE, &unlimited, nullptr);
  return {as_rc, rc_of(nofile)};
}


// ---- the channel, written raw on fd 3 (wire.hpp): what the SDK would never send ----

// One datagram on the channel: a header as given and `payload` after it (write(2): one SOCK_SEQPACKET record).
long send_frame(wire::FrameHeader h, std::string_view payload) {
  std::string bytes(sizeof h, '\0');
  std::memcpy(bytes.data(), &h, sizeof h);
  bytes += payload;
  return ::write(wire::kChannelFd, bytes.data(), bytes.size());
}

wire::FrameHeader header(wire::FrameKind kind, std::size_t length, std::uint32_t slot = 0, std::uint64_t aux = 0) {
  return wire::FrameHeader{.kind = static_cast<std::uint16_t>(kind), .flags = 0, .slot = slot, .seq = 0,
                           .length = static_cast<std::uint32_t>(length), .aux = aux};
}

// A ULog logged-string message ('L', docs/ulog.md) as the writer lays it out: size, type, level, timestamp, text.
std::string ulog_line(std::string_view text) {
  std::string m;
  const auto size = static_cast<std::uint16_t>(1 + 8 + text.size());
  m.append(reinterpret_cast<const char*>(&size), 2);  // NOLINT: the wire's bytes
  m += 'L';
  m += '3';  // ERR
  m.append(8, '\0');
  m += text;
  return m;
}

// Log lines and a publication that look like the kernel's log lines and like ULog messages: as Log frames
// (after a newline, a carriage return, as a whole ULog 'L' message) and inside a publication's payload on
// `numbers` (of the right size, and one byte too long).
Outcome forge_log(const Target& t) {
  const std::string mark(kForgedMark);
  long sent = 0;
  const auto log = [&](const std::string& text) {
    wire::LogHeader lh{};
    lh.level = static_cast<std::uint8_t>(wire::LogLevel::Error);
    std::string body(sizeof lh, '\0');
    std::memcpy(body.data(), &lh, sizeof lh);
    body += text;
    if (send_frame(header(wire::FrameKind::Log, body.size()), body) > 0) ++sent;
  };
  log("kernel: " + mark + " plain");
  log("innocent\nkernel: " + mark + " after-newline");
  log("innocent\r[kernel    1.000] " + mark + " after-cr");
  log(ulog_line("kernel: " + mark + " ulog-message"));
  const std::string printed = "kernel: " + mark + " stdout\n";
  if (::write(1, printed.data(), printed.size()) > 0) ++sent;
  std::string payload;
  while (payload.size() < t.numbers_size) payload += ulog_line("kernel: " + mark + " data");
  payload.resize(t.numbers_size);
  if (send_frame(header(wire::FrameKind::Publish, payload.size(), t.numbers_slot), payload) > 0) ++sent;
  payload += 'L';
  if (send_frame(header(wire::FrameKind::Publish, payload.size(), t.numbers_slot), payload) > 0) ++sent;
  return {static_cast<double>(sent), 0};
}

// Frames broken in every field the header has, each its own datagram: the kernel refuses each (counted as a
// bad frame, a denial or a wrong size) and reads on. Returns how many of the kBadFramesSent went out.
Outcome bad_frames(const Target& t) {
  long sent = 0;
  const auto count = [&](long rc) {
    if (rc > 0) ++sent;
  };
  const std::string eight(8, '\0');
  count(::write(wire::kChannelFd, eight.data(), eight.size()));                            // shorter than a header
  count(send_frame(header(wire::FrameKind::Log, 0xFFFF'FFFFU), eight));                    // length: 4 GiB
  count(send_frame(header(wire::FrameKind::Log, 100), eight));                             // length > datagram
  count(send_frame(wire::FrameHeader{.kind = 0x7FFF, .flags = 0, .slot = 0, .seq = 0, .length = 0, .aux = 0}, ""));
  count(send_frame(header(wire::FrameKind::Deliver, 0, t.numbers_slot), ""));  // a kernel → service kind
  count(send_frame(wire::FrameHeader{.kind = static_cast<std::uint16_t>(wire::FrameKind::Idle), .flags = 0xFFFF,
                                     .slot = 0, .seq = 0, .length = 0, .aux = 0},
                   ""));  // reserved flags
  count(send_frame(header(wire::FrameKind::Hello, 0, 0, wire::kProtocolVersion), ""));  // Hello after boot
  count(send_frame(header(wire::FrameKind::Ready, 0), ""));                               // Ready after boot
  const wire::TimerSpec never{.id = 77, .first_ns = ~std::uint64_t{0}, .period_ns = ~std::uint64_t{0}};
  count(send_frame(header(wire::FrameKind::TimerArm, sizeof never),
                   std::string_view(reinterpret_cast<const char*>(&never), sizeof never)));  // NOLINT: bytes
  const std::string huge(wire::kMaxFrameBytes + 512, 'x');
  wire::FrameHeader big = header(wire::FrameKind::Log, huge.size());
  count(send_frame(big, huge));  // longer than the longest frame: truncated on receive
  count(send_frame(header(wire::FrameKind::Taken, 0, 0, ~std::uint64_t{0}), ""));  // a checkpoint never asked
  // Refused otherwise: a publication on a slot it does not hold (a denial), of the wrong size (wrong_size), and
  // an Idle that counts more frames than the kernel ever sent.
  const std::string one(t.numbers_size, '\0');
  (void)send_frame(header(wire::FrameKind::Publish, one.size(), 0xFFFF'FFF0U), one);
  (void)send_frame(header(wire::FrameKind::Publish, 3, t.numbers_slot), "abc");
  (void)send_frame(header(wire::FrameKind::Idle, 0, 0, ~std::uint64_t{0}), "");
  return {static_cast<double>(sent), kBadFramesSent};
}

}  // namespace

std::optional<Outcome> perform(std::string_view escape, const Target& t) {
  // Fresh user and network namespaces, where a process is root and has its own interfaces.
  constexpr unsigned long kNewUser = CLONE_NEWUSER;
  const std::map<std::string_view, std::function<Outcome()>> table{
      {"udp_send", [&] { return udp_send(t); }},
      {"socketpair",
       [] {
         std::array<int, 2> fds{-1, -1};
         return Outcome{rc_of(::syscall(SYS_socketpair, AF_UNIX, SOCK_STREAM, 0, fds.data())), 0};
       }},
      {"io_uring", [&] { return io_uring_socket(t); }},
      {"open_passwd", [] { return open_path("/etc/passwd"); }},
      {"open_kernel_environ",
       [] { return open_path(("/proc/" + std::to_string(::getppid()) + "/environ").c_str()); }},
      {"create_file", [&] { return create_file(t); }},
      {"memfd_execveat", [] { return memfd_exec(); }},
      {"exec_sh", [] { return exec_sh(); }},
      {"mmap_rwx", [] { return mmap_rwx(); }},
      {"mprotect_exec", [] { return mprotect_exec(); }},
      {"ptrace_kernel", [] { return Outcome{rc_of(::syscall(SYS_ptrace, PTRACE_ATTACH, ::getppid(), 0, 0)), 0}; }},
      {"vm_readv_kernel", [&] { return vm_access(t, false); }},
      {"vm_writev_kernel", [&] { return vm_access(t, true); }},
      {"kill_other", [&] { return Outcome{rc_of(::syscall(SYS_kill, t.victim, SIGKILL)), 0}; }},
      {"tgkill_other", [&] { return Outcome{rc_of(::syscall(SYS_tgkill, t.victim, t.victim, SIGKILL)), 0}; }},
      {"fork",  // the C library's fork(): clone with CLONE_CHILD_SETTID | CLONE_CHILD_CLEARTID
       [] {
         const pid_t pid = ::fork();
         if (pid == 0) {
           if (::setsid() >= 0) sleep_forever();
           ::_exit(1);
         }
         return Outcome{rc_of(pid), static_cast<double>(pid)};
       }},
      {"helper_setsid", [] { return helper_setsid(); }},
      {"helper", [] { return helper(); }},
      {"clone_newuser",
       [] {
         const long pid = ::syscall(SYS_clone, kNewUser | SIGCHLD, nullptr, nullptr, nullptr, nullptr);
         if (pid == 0) sleep_forever();
         return Outcome{rc_of(pid), static_cast<double>(pid)};
       }},
      {"unshare_newuser", [] { return Outcome{rc_of(::syscall(SYS_unshare, kNewUser)), 0}; }},
      {"unshare_newnet", [] { return Outcome{rc_of(::syscall(SYS_unshare, CLONE_NEWNET)), 0}; }},
      {"setns", [] { return Outcome{rc_of(::syscall(SYS_setns, 1, CLONE_NEWNET)), 0}; }},
      {"sched_setaffinity",
       [] {
         cpu_set_t set;
         CPU_ZERO(&set);
         CPU_SET(0, &set);
         return Outcome{rc_of(::syscall(SYS_sched_setaffinity, 0, sizeof set, &set)), 0};
       }},
      {"raise_rlimit", [] { return raise_rlimit(); }},
      {"tiocsti",
       [&] {
         const char c = '\n';
         return Outcome{rc_of(::syscall(SYS_ioctl, t.fd, TIOCSTI, &c)), static_cast<double>(t.fd)};
       }},
      {"kill_first_incarnation",  // from a restored image: the pid the filter's "itself" check was made for
       [&] {
         if (t.epoch == 0) return Outcome{kNotTried, 0};
         return Outcome{rc_of(::syscall(SYS_kill, t.first_pid, 0)), static_cast<double>(t.first_pid)};
       }},
      {"fake_log", [] { return fake_log(); }},
      {"fork_bomb", [] { return fork_bomb(); }},
      {"memory_hog", [&] { return memory_hog(t); }},
      {"bpf", [] { return Outcome{rc_of(::syscall(SYS_bpf, 0, nullptr, 0)), 0}; }},
      {"perf_event_open",
       [] { return Outcome{rc_of(::syscall(SYS_perf_event_open, nullptr, 0, -1, -1, 0)), 0}; }},
      {"keyctl", [] { return Outcome{rc_of(::syscall(SYS_keyctl, 0 /* KEYCTL_GET_KEYRING_ID */, -3, 0)), 0}; }},
      {"forge_log", [&] { return forge_log(t); }},
      {"bad_frames", [&] { return bad_frames(t); }},
      {"stop_reading", [] { sleep_forever(); return Outcome{}; }},  // never reads its channel again
  };
  const auto it = table.find(escape);
  if (it == table.end()) return std::nullopt;
  return it->second();
}

}  // namespace rejuv::test_services::escapes
