#include "rejuv/sys/fd.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace rejuv::sys {

std::string SysError::to_string() const { return std::string(call) + ": " + std::strerror(error); }

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

}  // namespace rejuv::sys
