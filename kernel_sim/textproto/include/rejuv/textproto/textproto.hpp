// Loading protobuf text-format files (policy, launch graph) with precise errors (docs/conventions.md: bad user
// input gives file:line:column and what was expected; it never aborts).
#pragma once

#include <filesystem>
#include <memory>
#include <span>
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
  Syntax,      // not UTF-8 text, not of the schema's kind, or not valid text format for the schema: unknown
               // field, bad value, duplicate field
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
  // Falls back to the nearest enclosing location that is known, then to the file itself. In a composed file
  // (load_composed_textproto) the location is in the fragment that wrote the field: an element of a repeated
  // field is in the file that holds it, a singular field in the last file that set it.
  [[nodiscard]] SourceLocation locate(std::initializer_list<Step> path, std::string_view field,
                                      int index = -1) const;
  [[nodiscard]] SourceLocation locate(std::span<const Step> path, std::string_view field, int index = -1) const;
  // Whether `field` was written in any file (not merely its enclosing message).
  [[nodiscard]] bool written(std::span<const Step> path, std::string_view field, int index = -1) const;
  // The root file (the one loaded; a composed file's fragments are in files()).
  [[nodiscard]] SourceLocation file_only() const { return SourceLocation{file_, 0, 0}; }
  [[nodiscard]] const std::string& file() const { return file_; }
  // Every file the message was read from: the fragments in the order they were merged, the root file last.
  [[nodiscard]] std::vector<std::string> files() const;

 private:
  friend class Composer;
  std::string file_;
  std::unique_ptr<Impl> impl_;
};

// Largest text file accepted (a policy or launch graph is a few KiB; this bounds memory on bad input).
inline constexpr std::size_t kMaxTextprotoBytes = 4U << 20U;

// ---- What is refused (every file: the one loaded and each it includes) ----
//
// The loader may run as root and a fragment's `include` may name any path, so a file that is not a text file
// of the expected kind is refused by its path and the reason, never by what it holds:
//   - CannotRead at file:1:1 when it is not a regular file (a FIFO, a directory, a device or a socket: refused
//     from its stat(2) and never opened; opened O_NONBLOCK and checked again with fstat(2)), is larger than
//     kMaxTextprotoBytes, or cannot be read;
//   - Syntax at the first offending character when it is not UTF-8 text: a NUL byte, another control
//     character than tab, LF and CR (C0, DEL, C1), or a malformed UTF-8 sequence;
//   - Syntax at its first word when that word (after `#` comments) is not a field of the expected message: "not
//     a Launch file (its first word, at line 1, column 1, is no field of rejuv.proto.Launch)". An empty file,
//     or one of comments only, is a fragment of any kind.
// An included file (and an ExtraFragment) is refused at the `include` line that names it, `cannot include
// "path": …`. A syntax error further into an included file is reported at its own file:line:column with the
// class of error and what the parser expected (`no such field in rejuv.proto.ServiceSpec`, `expected ":"`),
// never with a word of the file; only the file the caller names (load_*, parse_*) has the word at fault
// quoted, as protobuf words it (`… has no field named "bogus"`). What such an error still tells is where the
// first difference from the schema is, and whether a file exists and is a regular file.

// Reads and parses `path` into `out` (cleared first). On success returns where every field was written.
[[nodiscard]] Result<TextLocations, LoadError> load_textproto(const std::filesystem::path& path,
                                                              google::protobuf::Message& out);

// The same from a string, `name` standing for the file in messages (tests, fuzzing).
[[nodiscard]] Result<TextLocations, LoadError> parse_textproto(std::string_view text, std::string name,
                                                               google::protobuf::Message& out);

// ---- Composition: a file made of fragments (docs/writing_a_service.md "Graph fragments") ----
//
// A message type with a `repeated string include` field can name other files of the same type, each
// relative to the folder of the file that names it (ROS 2 launch includes). The file is the merge of its
// fragments, in order, and then of its own fields:
//   - repeated fields are appended (a fragment's services, grants, bridges, waypoints …);
//   - a singular field set by two fragments is refused at the second one's file:line:column, naming the
//     first; a field the including file sets itself overrides what its fragments set;
//   - a cycle, a file included twice, more than kMaxIncludeDepth levels or kMaxComposedFiles files are
//     refused at the `include` line.
// `include` is empty in the result; TextLocations::files() lists the files and every location is in the
// fragment that wrote the field. A type without an `include` field loads as one file.
inline constexpr int kMaxIncludeDepth = 8;
inline constexpr int kMaxComposedFiles = 64;

// A fragment named from outside the file (e.g. a launch graph's `policy_include` for its policy): merged as
// if the root file included it first; `named_at` is where it was named, for errors.
struct ExtraFragment {
  std::filesystem::path path;
  SourceLocation named_at;
};

[[nodiscard]] Result<TextLocations, LoadError> load_composed_textproto(const std::filesystem::path& path,
                                                                       google::protobuf::Message& out,
                                                                       std::span<const ExtraFragment> extra = {});

// The same with the root file's text given; its includes are resolved against `name`'s folder.
[[nodiscard]] Result<TextLocations, LoadError> parse_composed_textproto(std::string_view text, std::string name,
                                                                        google::protobuf::Message& out,
                                                                        std::span<const ExtraFragment> extra = {});

}  // namespace rejuv
