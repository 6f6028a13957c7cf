// Reading a small file named by a user (a launch graph, a policy, a fragment they include) without being led
// into what is not one: a FIFO that would block the reader, a device whose open has effects, a directory, a
// file that never ends (/proc, sysfs).
#pragma once

#include <fcntl.h>
#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// What a path names (stat(2) after symbolic links), or an open fd (fstat(2)).
enum class FileType : std::uint8_t { Regular, Directory, Fifo, Socket, CharDevice, BlockDevice, Other };
[[nodiscard]] std::string_view to_string(FileType type);  // "a FIFO", "a directory", …

// Why read_regular_file gave no text. `type` is set for NotRegular, `limit` for TooLarge, `sys` otherwise.
struct FileReadError {
  enum class Kind : std::uint8_t { NoSuchFile, NotRegular, TooLarge, CannotRead };
  Kind kind;
  FileType type = FileType::Other;
  SysError sys{};
  [[nodiscard]] std::string to_string(std::size_t limit) const;  // "not a regular file (a FIFO)", …
};

// The whole text of the regular file at `path`, if it is at most `max_bytes` long. What is not a regular file is
// refused from its stat(2), before it is opened; the file is then opened non-blocking (a FIFO swapped in after
// the stat neither blocks the open nor the read) and checked again on the open fd. A file that reports size 0
// and reads on (/proc, sysfs) is read no further than `max_bytes` + 1.
[[nodiscard]] Result<std::string, FileReadError> read_regular_file(const std::filesystem::path& path,
                                                                   std::size_t max_bytes);

// ---- implementation (header-only: its one user is the text loader, kernel_sim/textproto) ----

namespace file_detail {

inline FileType type_of(mode_t mode) {
  switch (mode & S_IFMT) {
    case S_IFREG: return FileType::Regular;
    case S_IFDIR: return FileType::Directory;
    case S_IFIFO: return FileType::Fifo;
    case S_IFSOCK: return FileType::Socket;
    case S_IFCHR: return FileType::CharDevice;
    case S_IFBLK: return FileType::BlockDevice;
    default: return FileType::Other;
  }
}

inline std::unexpected<FileReadError> cannot(std::string_view call) {
  const int e = errno;
  const auto kind = e == ENOENT || e == ENOTDIR ? FileReadError::Kind::NoSuchFile : FileReadError::Kind::CannotRead;
  return std::unexpected(FileReadError{kind, FileType::Other, SysError{call, e}});
}

inline std::unexpected<FileReadError> not_regular(FileType type) {
  return std::unexpected(FileReadError{FileReadError::Kind::NotRegular, type, SysError{}});
}

}  // namespace file_detail

inline std::string_view to_string(FileType type) {
  switch (type) {
    case FileType::Regular: return "a regular file";
    case FileType::Directory: return "a directory";
    case FileType::Fifo: return "a FIFO";
    case FileType::Socket: return "a socket";
    case FileType::CharDevice: return "a character device";
    case FileType::BlockDevice: return "a block device";
    case FileType::Other: return "neither a file nor a directory";
  }
  return "unknown";
}

inline std::string FileReadError::to_string(std::size_t limit) const {
  switch (kind) {
    case Kind::NoSuchFile: return "no such file";
    case Kind::NotRegular: return "not a regular file (" + std::string(sys::to_string(type)) + ")";
    case Kind::TooLarge: return "file is larger than " + std::to_string(limit) + " bytes";
    case Kind::CannotRead: return "cannot read: " + sys.to_string();
  }
  return "cannot read";
}

inline Result<std::string, FileReadError> read_regular_file(const std::filesystem::path& path, std::size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return file_detail::cannot("stat");
  if (file_detail::type_of(st.st_mode) != FileType::Regular) return file_detail::not_regular(file_detail::type_of(st.st_mode));
  const UniqueFd fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC));
  if (!fd) return file_detail::cannot("open");
  if (::fstat(fd.get(), &st) != 0) return file_detail::cannot("fstat");
  if (file_detail::type_of(st.st_mode) != FileType::Regular) return file_detail::not_regular(file_detail::type_of(st.st_mode));
  const auto too_large = std::unexpected(FileReadError{FileReadError::Kind::TooLarge, FileType::Regular, SysError{}});
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes) return too_large;
  // In chunks up to just past the bound (a chunk is a multiple of 8 bytes: /proc/<pid>/pagemap refuses others).
  std::string text;
  std::array<char, 64 * 1024> chunk{};
  while (text.size() <= max_bytes) {
    auto n = read_some(fd.get(), chunk);
    if (!n) return std::unexpected(FileReadError{FileReadError::Kind::CannotRead, FileType::Regular, n.error()});
    if (!*n) return std::unexpected(FileReadError{FileReadError::Kind::CannotRead, FileType::Regular,
                                                  SysError{"read", EAGAIN}});
    if (**n == 0) break;
    text.append(chunk.data(), **n);
  }
  if (text.size() > max_bytes) return too_large;
  return text;
}

}  // namespace rejuv::sys
