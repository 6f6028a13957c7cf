#include "rejuv/sys/event.hpp"

#include <fcntl.h>
#include <algorithm>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/epoll.h>
#include <sys/signalfd.h>
#include <sys/timerfd.h>
#include <time.h>
#include <sys/resource.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <utility>

namespace rejuv::sys {

namespace {
std::uint32_t epoll_bits(Interest interest) {
  std::uint32_t bits = EPOLLRDHUP;
  if (interest.readable) bits |= EPOLLIN;
  if (interest.writable) bits |= EPOLLOUT;
  return bits;
}
int timeout_ms(std::optional<Nanos> timeout) {
  if (!timeout) return -1;
  if (timeout->count() <= 0) return 0;
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(*timeout).count();
  return ms > 0x7FFFFFFF ? 0x7FFFFFFF : static_cast<int>(ms);
}
static_assert(sizeof(sigset_t) <= sizeof(unsigned long) * 16);
}  // namespace

SysResult<Epoll> Epoll::create() {
  UniqueFd fd(::epoll_create1(EPOLL_CLOEXEC));
  if (!fd) return last_error("epoll_create1");
  return Epoll(std::move(fd));
}

SysResult<void> Epoll::add(int fd, std::uint64_t token, Interest interest) const {
  epoll_event ev{};
  ev.events = epoll_bits(interest);
  ev.data.u64 = token;
  if (::epoll_ctl(fd_.get(), EPOLL_CTL_ADD, fd, &ev) != 0) return last_error("epoll_ctl(ADD)");
  return {};
}

SysResult<void> Epoll::modify(int fd, std::uint64_t token, Interest interest) const {
  epoll_event ev{};
  ev.events = epoll_bits(interest);
  ev.data.u64 = token;
  if (::epoll_ctl(fd_.get(), EPOLL_CTL_MOD, fd, &ev) != 0) return last_error("epoll_ctl(MOD)");
  return {};
}

SysResult<void> Epoll::remove(int fd) const {
  if (::epoll_ctl(fd_.get(), EPOLL_CTL_DEL, fd, nullptr) != 0) return last_error("epoll_ctl(DEL)");
  return {};
}

SysResult<std::size_t> Epoll::wait(std::span<Event> out, std::optional<Nanos> timeout) const {
  std::array<epoll_event, 64> raw{};
  const int max = static_cast<int>(std::min(out.size(), raw.size()));
  int n = -1;
  do {
    n = ::epoll_wait(fd_.get(), raw.data(), max, timeout_ms(timeout));
  } while (n < 0 && errno == EINTR);
  if (n < 0) return last_error("epoll_wait");
  for (int i = 0; i < n; ++i) {
    const epoll_event& e = raw[static_cast<std::size_t>(i)];
    out[static_cast<std::size_t>(i)] = Event{.token = e.data.u64,
                                             .readable = (e.events & EPOLLIN) != 0,
                                             .writable = (e.events & EPOLLOUT) != 0,
                                             .hangup = (e.events & (EPOLLHUP | EPOLLRDHUP)) != 0,
                                             .error = (e.events & EPOLLERR) != 0};
  }
  return static_cast<std::size_t>(n);
}

SysResult<SignalFd> SignalFd::create(std::initializer_list<int> signals) {
  sigset_t set;
  sigemptyset(&set);
  for (const int s : signals) sigaddset(&set, s);
  Mask old;
  sigset_t old_set;
  if (const int rc = ::pthread_sigmask(SIG_BLOCK, &set, &old_set); rc != 0) {
    return std::unexpected(SysError{"pthread_sigmask", rc});
  }
  std::memcpy(old.words, &old_set, sizeof(old_set));
  UniqueFd fd(::signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC));
  if (!fd) {
    auto err = last_error("signalfd");
    ::pthread_sigmask(SIG_SETMASK, &old_set, nullptr);
    return err;
  }
  return SignalFd(std::move(fd), old);
}

SignalFd::SignalFd(SignalFd&& other) noexcept
    : fd_(std::move(other.fd_)), old_(other.old_), restore_(std::exchange(other.restore_, false)) {}

SignalFd::~SignalFd() {
  if (restore_) {
    // Drop what is pending for our signals before unblocking, so that a SIGINT already handled through
    // the fd is not delivered again with its default action.
    fd_.reset();
    sigset_t old_set;
    std::memcpy(&old_set, old_.words, sizeof(old_set));
    ::pthread_sigmask(SIG_SETMASK, &old_set, nullptr);
  }
}

SysResult<std::optional<int>> SignalFd::read() const {
  signalfd_siginfo info{};
  ssize_t n = -1;
  do {
    n = ::read(fd_.get(), &info, sizeof(info));
  } while (n < 0 && errno == EINTR);
  if (n < 0) {
    if (errno == EAGAIN) return std::optional<int>{};
    return last_error("read(signalfd)");
  }
  if (n != static_cast<ssize_t>(sizeof(info))) return std::unexpected(SysError{"read(signalfd)", EIO});
  return std::optional<int>(static_cast<int>(info.ssi_signo));
}

SysResult<TimerFd> TimerFd::create() {
  UniqueFd fd(::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC));
  if (!fd) return last_error("timerfd_create");
  return TimerFd(std::move(fd));
}

SysResult<void> TimerFd::arm_at(std::optional<Nanos> at) const {
  itimerspec spec{};
  if (at) {
    const std::int64_t ns = std::max<std::int64_t>(at->count(), 1);
    spec.it_value.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
    spec.it_value.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  }
  if (::timerfd_settime(fd_.get(), TFD_TIMER_ABSTIME, &spec, nullptr) != 0) return last_error("timerfd_settime");
  return {};
}

SysResult<std::uint64_t> TimerFd::consume() const {
  std::uint64_t count = 0;
  const ssize_t n = ::read(fd_.get(), &count, sizeof(count));
  if (n < 0) {
    if (errno == EAGAIN) return std::uint64_t{0};
    return last_error("read(timerfd)");
  }
  return count;
}

Nanos monotonic_now() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return Nanos(static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec);
}

SysResult<void> set_nonblocking(int fd, bool nonblocking) {
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0) return last_error("fcntl(F_GETFL)");
  const int wanted = nonblocking ? (flags | O_NONBLOCK) : (flags & ~O_NONBLOCK);
  if (wanted != flags && ::fcntl(fd, F_SETFL, wanted) != 0) return last_error("fcntl(F_SETFL)");
  return {};
}

SysResult<bool> wait_fd(int fd, WaitFor what, std::optional<Nanos> timeout) {
  pollfd p{fd, static_cast<short>(what == WaitFor::Readable ? POLLIN : POLLOUT), 0};
  int n = -1;
  do {
    n = ::poll(&p, 1, timeout_ms(timeout));
  } while (n < 0 && errno == EINTR);
  if (n < 0) return last_error("poll");
  return n > 0;
}

bool fd_is_open(int fd) { return ::fcntl(fd, F_GETFD) != -1; }

int current_pid() { return static_cast<int>(::getpid()); }

bool running_as_root() { return ::geteuid() == 0; }

SysResult<std::uint64_t> ensure_open_files(std::uint64_t wanted) {
  rlimit lim{};
  if (::getrlimit(RLIMIT_NOFILE, &lim) != 0) return last_error("getrlimit(RLIMIT_NOFILE)");
  if (lim.rlim_cur >= wanted) return static_cast<std::uint64_t>(lim.rlim_cur);
  rlimit raised = lim;
  raised.rlim_cur = lim.rlim_max == RLIM_INFINITY ? 2 * wanted : std::min<rlim_t>(lim.rlim_max, 2 * wanted);
  if (raised.rlim_cur > lim.rlim_cur && ::setrlimit(RLIMIT_NOFILE, &raised) == 0) return static_cast<std::uint64_t>(raised.rlim_cur);
  return static_cast<std::uint64_t>(lim.rlim_cur);
}

}  // namespace rejuv::sys
