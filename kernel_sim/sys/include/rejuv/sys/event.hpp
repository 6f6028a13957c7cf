// Event sources of the kernel's event loop (docs/design.md §2, §6): epoll, signalfd, timerfd, and the fd flags
// and waits the service SDK needs. Thin RAII over the system calls; everything above is typed C++.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>

#include "rejuv/core/time.hpp"
#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// What an fd is watched for / what happened to it.
struct Interest {
  bool readable = true;
  bool writable = false;
};
struct Event {
  std::uint64_t token = 0;  // what the caller registered the fd with
  bool readable = false;
  bool writable = false;
  bool hangup = false;      // EPOLLHUP / EPOLLRDHUP
  bool error = false;       // EPOLLERR
};

// An epoll instance. Level-triggered: an fd stays reported while it is readable (writable).
class Epoll {
 public:
  [[nodiscard]] static SysResult<Epoll> create();
  [[nodiscard]] SysResult<void> add(int fd, std::uint64_t token, Interest interest = {}) const;
  [[nodiscard]] SysResult<void> modify(int fd, std::uint64_t token, Interest interest) const;
  [[nodiscard]] SysResult<void> remove(int fd) const;
  // Waits up to `timeout` (nullopt = forever; 0 = poll) and fills `out`; returns how many events.
  [[nodiscard]] SysResult<std::size_t> wait(std::span<Event> out, std::optional<Nanos> timeout) const;
  [[nodiscard]] int fd() const { return fd_.get(); }

 private:
  explicit Epoll(UniqueFd fd) : fd_(std::move(fd)) {}
  UniqueFd fd_;
};

// A signalfd for `signals`, which are blocked in the calling thread for the life of the object (and the
// previous mask restored afterwards). Create it before any other thread starts (Cyclone DDS), so that
// every thread inherits the blocked mask and the signal reaches only this fd.
class SignalFd {
 public:
  [[nodiscard]] static SysResult<SignalFd> create(std::initializer_list<int> signals);
  SignalFd(SignalFd&& other) noexcept;
  SignalFd& operator=(SignalFd&&) = delete;
  SignalFd(const SignalFd&) = delete;
  SignalFd& operator=(const SignalFd&) = delete;
  ~SignalFd();
  // The next pending signal number, or nullopt when none is pending (non-blocking).
  [[nodiscard]] SysResult<std::optional<int>> read() const;
  [[nodiscard]] int fd() const { return fd_.get(); }

 private:
  struct Mask {
    unsigned long words[16] = {};  // sigset_t storage (glibc: 1024 bits)
  };
  SignalFd(UniqueFd fd, const Mask& old) : fd_(std::move(fd)), old_(old), restore_(true) {}
  UniqueFd fd_;
  Mask old_{};
  bool restore_ = false;
};

// A CLOCK_MONOTONIC timerfd (non-blocking).
class TimerFd {
 public:
  [[nodiscard]] static SysResult<TimerFd> create();
  // Fires once at absolute monotonic time `at` (nullopt disarms).
  [[nodiscard]] SysResult<void> arm_at(std::optional<Nanos> at) const;
  // Consumes the expiry count (0 if it had not fired).
  [[nodiscard]] SysResult<std::uint64_t> consume() const;
  [[nodiscard]] int fd() const { return fd_.get(); }

 private:
  explicit TimerFd(UniqueFd fd) : fd_(std::move(fd)) {}
  UniqueFd fd_;
};

// CLOCK_MONOTONIC now [ns].
[[nodiscard]] Nanos monotonic_now();

// Sets or clears O_NONBLOCK on an fd (shared by every holder of the open file description).
[[nodiscard]] SysResult<void> set_nonblocking(int fd, bool nonblocking);

// Waits until `fd` is readable (or writable); false on timeout. nullopt = forever.
enum class WaitFor : std::uint8_t { Readable, Writable };
[[nodiscard]] SysResult<bool> wait_fd(int fd, WaitFor what, std::optional<Nanos> timeout);

// Whether an fd number is open in this process.
[[nodiscard]] bool fd_is_open(int fd);

// The process id and whether this process runs as root (effective uid 0).
[[nodiscard]] int current_pid();
[[nodiscard]] bool running_as_root();

// Makes sure this process may open at least `wanted` fds: raises its soft RLIMIT_NOFILE towards the hard one
// (up to 2 × wanted) when it is below. Returns the soft limit it ends with, which may still be below `wanted`.
[[nodiscard]] SysResult<std::uint64_t> ensure_open_files(std::uint64_t wanted);

}  // namespace rejuv::sys
