// A restricted IDL parser: the subset of OMG IDL 4 that the project's topic types are written in (idl/*.idl),
// read to generate the ROS 2 interface package rejuv_msgs (package.hpp; docs/across_hosts.md "ROS 2 names").
// What it reads: `module`, `@final struct` with one member per declaration, fixed one-dimensional arrays
// `T x[N]`, `enum` without values, the integer, floating-point, boolean, octet and char types (IDL 4's int8 …
// uint64 and the classic spellings: long, unsigned long long, …), struct and enum names (scoped or not,
// declared before use), `#include "file.idl"` (followed, relative to the including file), `//` and `/* */`
// comments. Everything else — sequences, strings, unions, typedefs, constants, other annotations, bounded or
// multi-dimensional arrays — is refused at its file:line:column with what was found and what the generator
// reads, never guessed: the generated messages must be the structs' CDR exactly.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"

namespace rejuv::ros2_msgs {

struct SourcePos {
  std::string file;  // as given (a path, or a name for text parsed from memory)
  int line = 0;      // 1-based
  int column = 0;    // 1-based, in bytes
};

struct IdlError {
  SourcePos at;
  std::string message;
  // "idl/sr.idl:12:3: error: sequence<T> (a variable-length member) is not supported: …" ("FILE: error: …"
  // for a file as a whole).
  [[nodiscard]] std::string to_string() const;
};

// A primitive IDL type, by its CDR size and kind.
enum class Primitive : std::uint8_t { Bool, Char, Int8, Uint8, Int16, Uint16, Int32, Uint32, Int64, Uint64, Float32, Float64 };

// A member's type: a primitive, or a struct or enum declared earlier (its scoped name, "rejuv::msg::Waypoint").
struct MemberType {
  enum class Kind : std::uint8_t { Primitive, Struct, Enum };
  Kind kind = Kind::Primitive;
  Primitive primitive = Primitive::Int32;  // Kind::Primitive
  std::string scoped_name{};               // Kind::Struct, Kind::Enum
};

struct Member {
  std::string name;
  MemberType type;
  std::optional<std::uint32_t> array_size{};  // T x[N]
  std::string comment{};                      // the `//` comment after it (and its continuation lines)
  SourcePos at;
};

struct Struct {
  std::string scoped_name;  // "rejuv::msg::SensorGyro"
  std::string name;         // "SensorGyro"
  std::vector<Member> members;
  std::string comment{};    // the `//` lines right above it
  std::string file{};       // the .idl file's name (no folder)
  SourcePos at;
};

struct Enum {
  std::string scoped_name;
  std::string name;
  std::vector<std::string> enumerators;  // value = index (IDL's default)
  SourcePos at;
};

// Every declaration of a set of IDL files, in declaration order (an included file's before its includer's).
struct Definitions {
  std::vector<Struct> structs;
  std::vector<Enum> enums;

  [[nodiscard]] const Struct* find_struct(std::string_view scoped_name) const;
  [[nodiscard]] const Enum* find_enum(std::string_view scoped_name) const;
};

// What `#include "name"` does: reads that file into the same Definitions (load_idl), or fails.
using IncludeFn = std::function<Result<void, IdlError>(std::string_view name, const SourcePos& at)>;

// Parses `text` (named `file` in errors) into `defs`, after what is already there (a later file may use an
// earlier file's types). Without `include`, an `#include` is refused.
[[nodiscard]] Result<void, IdlError> parse_idl(std::string_view text, const std::string& file, Definitions& defs,
                                               const IncludeFn& include = {});

// Reads the files in order, each once, following `#include "x.idl"` relative to the including file's folder
// (an included file is read before the rest of its includer).
[[nodiscard]] Result<Definitions, IdlError> load_idl(std::span<const std::filesystem::path> files);

}  // namespace rejuv::ros2_msgs
