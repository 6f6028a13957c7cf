// The system-call layer (docs/conventions.md: the system calls live in kernel_sim/sys, the way Rust confines
// `unsafe`; everything above it is typed C++). This header: errors from system calls and owned fds.
#pragma once

#include <string>
#include <optional>
#include <span>
#include <string_view>

#include "rejuv/core/result.hpp"

namespace rejuv::sys {

// A failed system call: which call and errno. A helper program that failed (newuidmap) has errno 0 and says
// what it wrote to stderr in `detail`.
struct SysError {
  std::string_view call;
  int error = 0;
  std::string detail{};
  [[nodiscard]] std::string to_string() const;  // "socketpair: Too many open files"
};

template <class T>
using SysResult = Result<T, SysError>;

// errno of the last call, as an error value.
[[nodiscard]] std::unexpected<SysError> last_error(std::string_view call);

// An owned file descriptor: closed on destruction, move-only, empty after a move; closing twice is safe.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  UniqueFd(UniqueFd&& other) noexcept : fd_(other.release()) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept;
  ~UniqueFd() { reset(); }

  [[nodiscard]] int get() const { return fd_; }
  [[nodiscard]] bool valid() const { return fd_ >= 0; }
  explicit operator bool() const { return valid(); }
  // Gives up ownership without closing.
  [[nodiscard]] int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }
  void reset(int fd = -1);
  // A second owned fd for the same open file (close-on-exec).
  [[nodiscard]] SysResult<UniqueFd> duplicate() const;

 private:
  int fd_ = -1;
};

// Number of open fds of this process (counts /proc/self/fd), for leak checks.
// Moves `fd` to the number `target` (dup2, then closes the original): a restored image takes its new
// channel at fd 3 (docs/design.md §7). Whatever was open at `target` is closed.
[[nodiscard]] SysResult<void> install_fd(UniqueFd fd, int target);
[[nodiscard]] SysResult<int> count_open_fds();

// A pipe: {read end (non-blocking), write end (blocking)}, both close-on-exec (a spawn places the write end).
struct Pipe {
  UniqueFd read;
  UniqueFd write;
};
[[nodiscard]] SysResult<Pipe> make_pipe();
// /dev/null opened read-only (a service's fd 0: it has no terminal to read).
[[nodiscard]] SysResult<UniqueFd> open_null();
// Reads what is there without waiting: the byte count, 0 at end of file, nullopt when nothing waits.
[[nodiscard]] SysResult<std::optional<std::size_t>> read_some(int fd, std::span<char> into);

}  // namespace rejuv::sys
