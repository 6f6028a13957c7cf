#include "rejuv/sys/fd.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

namespace rejuv::sys {

std::string SysError::to_string() const {
  std::string out(call);
  if (error != 0) out += std::string(": ") + std::strerror(error);
  if (!detail.empty()) out += ": " + detail;
  return out;
}

std::unexpected<SysError> last_error(std::string_view call) { return std::unexpected(SysError{call, errno}); }

UniqueFd& UniqueFd::operator=(UniqueFd&& other) noexcept {
  if (this != &other) {
    reset(other.release());
  }
  return *this;
}

void UniqueFd::reset(int fd) {
  if (fd_ >= 0) {
    ::close(fd_);  // EINTR on Linux still closes the fd: never retry
  }
  fd_ = fd;
}

SysResult<UniqueFd> UniqueFd::duplicate() const {
  const int fd = ::fcntl(fd_, F_DUPFD_CLOEXEC, 0);
  if (fd < 0) {
    return last_error("fcntl(F_DUPFD_CLOEXEC)");
  }
  return UniqueFd(fd);
}

SysResult<void> install_fd(UniqueFd fd, int target) {
  if (fd.get() == target) {
    (void)fd.release();
    return {};
  }
  if (::dup2(fd.get(), target) < 0) return last_error("dup2");
  return {};  // `fd` closes the original
}

SysResult<int> count_open_fds() {
  DIR* dir = ::opendir("/proc/self/fd");
  if (dir == nullptr) {
    return last_error("opendir(/proc/self/fd)");
  }
  int count = 0;
  while (const dirent* entry = ::readdir(dir)) {
    if (entry->d_name[0] != '.') {
      ++count;
    }
  }
  ::closedir(dir);
  return count - 1;  // the directory stream's own fd
}

SysResult<Pipe> make_pipe() {
  std::array<int, 2> fds{-1, -1};
  if (::pipe2(fds.data(), O_CLOEXEC) != 0) return last_error("pipe2");
  Pipe p{UniqueFd(fds[0]), UniqueFd(fds[1])};
  const int flags = ::fcntl(p.read.get(), F_GETFL);
  if (flags < 0 || ::fcntl(p.read.get(), F_SETFL, flags | O_NONBLOCK) != 0) return last_error("fcntl(O_NONBLOCK)");
  return p;
}

SysResult<UniqueFd> open_null() {
  UniqueFd fd(::open("/dev/null", O_RDONLY | O_CLOEXEC));
  if (!fd) return last_error("open(/dev/null)");
  return fd;
}

SysResult<std::optional<std::size_t>> read_some(int fd, std::span<char> into) {
  for (;;) {
    const ssize_t n = ::read(fd, into.data(), into.size());
    if (n >= 0) return std::optional<std::size_t>{static_cast<std::size_t>(n)};
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return std::optional<std::size_t>{};
    return last_error("read");
  }
}

}  // namespace rejuv::sys
