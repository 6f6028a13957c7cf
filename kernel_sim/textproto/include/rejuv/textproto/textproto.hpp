// Loading protobuf text-format files (policy, launch graph) with precise errors (CONVENTIONS: bad user
// input gives file:line:column and what was expected; it never aborts).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rejuv/core/result.hpp"

namespace google::protobuf {
class Message;
}  // namespace google::protobuf

namespace rejuv {

// A place in a text file; line and column are 1-based (0 = unknown).
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;
  [[nodiscard]] std::string to_string() const;  // "file:line:column"
};

enum class LoadErrorKind : std::uint8_t {
  CannotRead,  // missing, unreadable, not a regular file or too large
  Syntax,      // not valid text format for the schema: unknown field, bad value, duplicate field
  Semantic,    // parsed, but the content is wrong (unknown name, duplicate, bad rights, ...)
};

struct LoadError {
  LoadErrorKind kind;
  SourceLocation where;
  std::string message;
  [[nodiscard]] std::string to_string() const;  // "file:line:column: error: message"
};

// A semantic error at `where`. A field that was never written has no line: it falls back to the start of
// the file, so that every error has a place to jump to.
[[nodiscard]] LoadError semantic_error(SourceLocation where, std::string message);

// Where each field of a parsed file was written, for semantic errors found after parsing.
class TextLocations {
 public:
  // One step of a path into nested messages: field name and index (-1 for a singular field).
  struct Step {
    std::string_view field;
    int index = -1;
  };

  struct Impl;  // the parser's location tree (protobuf's TextFormat::ParseInfoTree)
  TextLocations(std::string file, std::unique_ptr<Impl> impl);
  TextLocations(TextLocations&&) noexcept;
  TextLocations& operator=(TextLocations&&) noexcept;
  ~TextLocations();

  // Location of `field` (element `index` if repeated) in the message reached by `path` from the root.
  // Falls back to the nearest enclosing location that is known, then to the file itself.
  [[nodiscard]] SourceLocation locate(std::initializer_list<Step> path, std::string_view field,
                                      int index = -1) const;
  [[nodiscard]] SourceLocation file_only() const { return SourceLocation{file_, 0, 0}; }
  [[nodiscard]] const std::string& file() const { return file_; }

 private:
  std::string file_;
  std::unique_ptr<Impl> impl_;
};

// Largest text file accepted (a policy or launch graph is a few KiB; this bounds memory on bad input).
inline constexpr std::size_t kMaxTextprotoBytes = 4U << 20U;

// Reads and parses `path` into `out` (cleared first). On success returns where every field was written.
[[nodiscard]] Result<TextLocations, LoadError> load_textproto(const std::filesystem::path& path,
                                                              google::protobuf::Message& out);

// The same from a string, `name` standing for the file in messages (tests, fuzzing).
[[nodiscard]] Result<TextLocations, LoadError> parse_textproto(std::string_view text, std::string name,
                                                               google::protobuf::Message& out);

}  // namespace rejuv
