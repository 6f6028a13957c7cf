// Shared memory for the kernel's time page (docs/design.md §6): a memfd the kernel maps read-write and hands to
// services as a read-only fd, which they map read-only. Move-only RAII over mmap (docs/conventions.md `Mapping`).
#pragma once

#include <cstddef>
#include <span>
#include <string_view>
#include <utility>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

enum class Access : std::uint8_t { ReadOnly, ReadWrite };

// A shared mapping of a file (MAP_SHARED): unmapped on destruction, empty after a move.
class Mapping {
 public:
  Mapping() = default;
  // Maps `size` bytes of `fd` from offset 0. ReadWrite needs an fd opened for writing.
  [[nodiscard]] static SysResult<Mapping> map(const UniqueFd& fd, std::size_t size, Access access);
  [[nodiscard]] static SysResult<Mapping> map_fd(int fd, std::size_t size, Access access);
  Mapping(const Mapping&) = delete;
  Mapping& operator=(const Mapping&) = delete;
  Mapping(Mapping&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)),
        access_(other.access_) {}
  Mapping& operator=(Mapping&& other) noexcept;
  ~Mapping() { reset(); }

  [[nodiscard]] void* data() const { return data_; }
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] Access access() const { return access_; }
  [[nodiscard]] bool valid() const { return data_ != nullptr; }
  void reset() noexcept;

 private:
  Mapping(void* data, std::size_t size, Access access) : data_(data), size_(size), access_(access) {}
  void* data_ = nullptr;
  std::size_t size_ = 0;
  Access access_ = Access::ReadOnly;
};

// An anonymous memory file of `size` bytes (zero-filled, close-on-exec), sealed against shrinking and
// growing so that no holder of an fd can make a mapping of it fault (SIGBUS) in another process. Further
// seals may still be added (seal_against_writes).
[[nodiscard]] SysResult<UniqueFd> make_memfd(std::string_view name, std::size_t size);

// Seals a memfd from make_memfd against every write that is not already mapped (F_SEAL_FUTURE_WRITE: the
// caller's own read-write mapping, made before, keeps writing; a write(), a pwrite() or a new writable mapping
// through ANY fd of it — including one reopened O_RDWR through /proc/<pid>/fd — fails with EPERM), then
// against any further seal change (F_SEAL_SEAL), and sets its mode to 0444. For the pages the kernel shares
// with services (the time page): a service given a read-only fd must not get a writable one by a magic link.
[[nodiscard]] SysResult<void> seal_against_writes(const UniqueFd& fd);

// A new, independent open file description of the same file, read-only (through /proc/self/fd): what a
// service receives, so that it can neither write the file nor map it writable.
[[nodiscard]] SysResult<UniqueFd> reopen_read_only(const UniqueFd& fd);

}  // namespace rejuv::sys
