#include "rejuv/sys/memory.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <string>

namespace rejuv::sys {

SysResult<Mapping> Mapping::map(const UniqueFd& fd, std::size_t size, Access access) {
  return map_fd(fd.get(), size, access);
}

SysResult<Mapping> Mapping::map_fd(int fd, std::size_t size, Access access) {
  if (size == 0) {
    return std::unexpected(SysError{"mmap", EINVAL});
  }
  const int prot = access == Access::ReadWrite ? (PROT_READ | PROT_WRITE) : PROT_READ;
  void* data = ::mmap(nullptr, size, prot, MAP_SHARED, fd, 0);
  if (data == MAP_FAILED) {
    return last_error("mmap");
  }
  return Mapping(data, size, access);
}

Mapping& Mapping::operator=(Mapping&& other) noexcept {
  if (this != &other) {
    reset();
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    access_ = other.access_;
  }
  return *this;
}

void Mapping::reset() noexcept {
  if (data_ != nullptr) {
    ::munmap(data_, size_);
    data_ = nullptr;
    size_ = 0;
  }
}

SysResult<UniqueFd> make_memfd(std::string_view name, std::size_t size) {
  const std::string n(name);
  UniqueFd fd(::memfd_create(n.c_str(), MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (!fd) {
    return last_error("memfd_create");
  }
  if (::ftruncate(fd.get(), static_cast<off_t>(size)) != 0) {
    return last_error("ftruncate");
  }
  if (::fcntl(fd.get(), F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW) != 0) {
    return last_error("fcntl(F_ADD_SEALS)");
  }
  return fd;
}

SysResult<void> seal_against_writes(const UniqueFd& fd) {
  if (::fcntl(fd.get(), F_ADD_SEALS, F_SEAL_FUTURE_WRITE | F_SEAL_SEAL) != 0) {
    return last_error("fcntl(F_ADD_SEALS, F_SEAL_FUTURE_WRITE)");
  }
  if (::fchmod(fd.get(), 0444) != 0) return last_error("fchmod(0444)");
  return {};
}

SysResult<UniqueFd> reopen_read_only(const UniqueFd& fd) {
  const std::string path = "/proc/self/fd/" + std::to_string(fd.get());
  UniqueFd ro(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!ro) {
    return last_error("open(/proc/self/fd)");
  }
  return ro;
}

}  // namespace rejuv::sys
