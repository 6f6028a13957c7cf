// A writer of PX4's ULog format (docs.px4.io "ULog File Format"; docs/ulog.md): the logs `rejuv run --ulog`
// writes, which PlotJuggler, PX4 Flight Review and Foxglove open. Written from the specification, not from
// PX4's code. Little endian throughout; every message is a 3-byte header (uint16 payload size, uint8 type)
// and its payload, so a payload is at most 65535 bytes.
//
// A file is the 16-byte header (magic, version 1, start time [µs]), the flag bits ('B', first), the
// definitions (info 'I', parameters 'P', formats 'F') and the data ('A' subscriptions, 'D' data, 'L'
// logged strings, 'S' sync). Encoder keeps that order: a definition after the first data message is refused.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"

namespace rejuv::ulog {

inline constexpr std::size_t kMaxPayload = 0xFFFF;  // msg_size is a uint16
inline constexpr std::size_t kMaxKey = 0xFF;        // key_len of 'I' and 'P' is a uint8
inline constexpr std::array<std::uint8_t, 7> kMagic{0x55, 0x4C, 0x6F, 0x67, 0x01, 0x12, 0x35};  // "ULog" 01 12 35
inline constexpr std::array<std::uint8_t, 8> kSyncMagic{0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};

// Log levels of 'L' messages: the ASCII digits of syslog's levels.
enum class LogLevel : std::uint8_t {
  Emergency = '0', Alert = '1', Critical = '2', Error = '3', Warning = '4', Notice = '5', Info = '6', Debug = '7',
};

// One field of a format: a basic type ("double", "uint8_t", …) or the name of another format; `array` 0 is
// a scalar, N > 0 a fixed array of N. Names starting with `_padding` are skipped by readers.
struct Field {
  std::string type;
  std::string name;
  std::uint32_t array = 0;
};
// A format ('F'): "name:type0 field0;type1[N] field1;…".
struct Format {
  std::string name;
  std::vector<Field> fields;
};
[[nodiscard]] std::string format_text(const Format& format);
// Size in bytes of a basic ULog type; 0 for anything else.
[[nodiscard]] std::size_t basic_size(std::string_view type);

enum class UlogError : std::uint8_t {
  TooLong,           // a key, a name or a format does not fit its length field
  BadName,           // empty, or with a character that breaks the format syntax (':', ';', ' ', '[')
  UnknownType,       // a field's type is neither basic nor a format defined before
  DuplicateFormat,   // a format of that name was defined before
  UnknownFormat,     // add_logged of a name with no format
  NotADefinition,    // a definition ('I', 'P', 'F') after the data section began
  UnknownMsgId,      // data for a msg_id never added
  WrongSize,         // data whose size is not its format's
  TooManySubscriptions,  // msg_id is a uint16
  Io,                // the file could not be opened or written
};
[[nodiscard]] std::string_view to_string(UlogError e);

// Truncates `text` to at most `max` bytes without cutting a UTF-8 sequence.
[[nodiscard]] std::string_view truncate_utf8(std::string_view text, std::size_t max);

using MsgId = std::uint16_t;

// Encodes a ULog stream into a byte buffer (pure: the unit tests read its bytes). Holds the formats and
// subscriptions it has written, to check every data message against its format's size.
class Encoder {
 public:
  // The header and the flag bits (no compatible or incompatible flags, no appended data).
  explicit Encoder(std::uint64_t start_us);

  // 'I': a string (char[N]) or a basic value, e.g. info_string("sys_name", "Rejuv").
  [[nodiscard]] Result<void, UlogError> info_string(std::string_view key, std::string_view value);
  [[nodiscard]] Result<void, UlogError> info_u64(std::string_view key, std::uint64_t value);
  // 'P': ULog parameters are int32_t or float.
  [[nodiscard]] Result<void, UlogError> parameter(std::string_view name, float value);
  [[nodiscard]] Result<void, UlogError> parameter(std::string_view name, std::int32_t value);
  // 'F': every field's type is basic or a format defined before.
  [[nodiscard]] Result<void, UlogError> format(const Format& format);

  // 'A': subscribes to a format; the first call ends the definitions. msg_ids count from 0.
  [[nodiscard]] Result<MsgId, UlogError> add_logged(std::string_view format_name, std::uint8_t multi_id = 0);
  // 'D': `payload` is one message of the subscription's format, its first field the uint64 timestamp [µs].
  [[nodiscard]] Result<void, UlogError> data(MsgId id, std::span<const std::byte> payload);
  // 'L': a logged string at t_us; longer text is cut to what a message holds (at a UTF-8 boundary).
  void log(LogLevel level, std::uint64_t t_us, std::string_view text);
  // 'S': a sync marker, for readers that resynchronise after a corrupt stretch.
  void sync();

  [[nodiscard]] std::size_t format_size(std::string_view name) const;  // 0: no such format
  [[nodiscard]] bool in_data_section() const { return data_section_; }
  [[nodiscard]] std::span<const std::byte> bytes() const { return out_; }
  // Hands the encoded bytes over (a file writer flushes them) and starts an empty buffer.
  [[nodiscard]] std::vector<std::byte> take();

 private:
  void message(char type, std::span<const std::byte> payload);
  [[nodiscard]] Result<void, UlogError> key_value(char type, std::string_view key,
                                                  std::span<const std::byte> value, bool definition);

  std::vector<std::byte> out_;
  std::vector<std::byte> scratch_;
  std::map<std::string, std::size_t, std::less<>> format_sizes_;
  std::vector<std::size_t> subscription_sizes_;  // by MsgId
  bool data_section_ = false;
};

// An Encoder that streams to a file: the buffer goes to disk whenever it passes 256 KiB, and at close().
class FileWriter {
 public:
  [[nodiscard]] static Result<FileWriter, UlogError> create(const std::filesystem::path& path,
                                                            std::uint64_t start_us);
  [[nodiscard]] Encoder& encoder() { return enc_; }
  // Writes what is buffered if it is large; a failed write is remembered and returned by close().
  void flush_if_large();
  [[nodiscard]] Result<std::uint64_t, UlogError> close();  // the file's size in bytes
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  FileWriter(std::unique_ptr<std::FILE, Closer> file, std::filesystem::path path, std::uint64_t start_us)
      : file_(std::move(file)), path_(std::move(path)), enc_(start_us) {}
  void flush();

  std::unique_ptr<std::FILE, Closer> file_;
  std::filesystem::path path_;
  Encoder enc_;
  std::uint64_t written_ = 0;
  bool failed_ = false;
};

}  // namespace rejuv::ulog
