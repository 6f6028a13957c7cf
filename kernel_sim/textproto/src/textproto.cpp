#include "rejuv/textproto/textproto.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/message.h>
#include <google/protobuf/text_format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <map>
#include <optional>
#include <system_error>
#include <vector>

#include "rejuv/core/did_you_mean.hpp"
#include "rejuv/sys/file.hpp"

namespace rejuv {

namespace pb = google::protobuf;

std::string SourceLocation::to_string() const {
  if (line <= 0) {
    return file;
  }
  return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

std::string LoadError::to_string() const { return where.to_string() + ": error: " + message; }

LoadError semantic_error(SourceLocation where, std::string message) {
  if (where.line <= 0) {
    where.line = 1;
    where.column = 1;
  }
  return LoadError{LoadErrorKind::Semantic, std::move(where), std::move(message)};
}

namespace {

// One file of a (possibly composed) message: its location tree, and for each repeated field reached through
// singular fields only ("services", "dds.bridges"), which elements of the merged message it holds.
struct Part {
  std::string file;
  std::unique_ptr<pb::TextFormat::ParseInfoTree> tree;
  std::map<std::string, std::pair<int, int>, std::less<>> ranges;  // key → [first, first + count)
};

// What one part knows of a field: the deepest location it has on the way (depth 0 = none), and whether it
// wrote the field itself. depth −1: the path names an element another part holds.
struct Found {
  SourceLocation where;
  int depth = 0;
  bool exact = false;
};

Found locate_in(const Part& part, const pb::Descriptor* root, std::span<const TextLocations::Step> path,
                std::string_view field, int index) {
  Found best{SourceLocation{part.file, 0, 0}, 0, false};
  const pb::Descriptor* desc = root;
  const pb::TextFormat::ParseInfoTree* tree = part.tree.get();
  std::string key;
  bool inside_element = false;  // below an element of a repeated field: it is wholly this part's
  int depth = 0;
  // The element's index within this part, or nullopt when another part holds it.
  const auto local = [&](const pb::FieldDescriptor* f, int i) -> std::optional<int> {
    key += (key.empty() ? "" : ".") + f->name();
    if (inside_element || !f->is_repeated() || i < 0) {
      return i;
    }
    const auto it = part.ranges.find(key);
    if (it == part.ranges.end() || i < it->second.first || i >= it->second.first + it->second.second) {
      return std::nullopt;
    }
    return i - it->second.first;
  };
  const auto remember = [&](const pb::FieldDescriptor* f, int i) {
    ++depth;
    const pb::TextFormat::ParseLocation loc = tree->GetLocation(f, i);
    if (loc.line >= 0) {
      best = Found{SourceLocation{part.file, loc.line + 1, loc.column + 1}, depth, false};
    }
    return loc.line >= 0;
  };
  for (const TextLocations::Step& step : path) {
    const pb::FieldDescriptor* f = desc->FindFieldByName(std::string(step.field));
    if (f == nullptr || f->message_type() == nullptr || tree == nullptr) {
      return best;
    }
    const std::optional<int> i = local(f, step.index);
    if (!i) {
      return Found{best.where, -1, false};
    }
    remember(f, *i);
    inside_element = inside_element || f->is_repeated();
    tree = tree->GetTreeForNested(f, *i);
    desc = f->message_type();
  }
  if (tree == nullptr) {
    return best;
  }
  if (const pb::FieldDescriptor* f = desc->FindFieldByName(std::string(field)); f != nullptr) {
    const std::optional<int> i = local(f, index);
    if (!i) {
      return Found{best.where, -1, false};
    }
    best.exact = remember(f, *i);
  }
  return best;
}

// The ranges of a freshly parsed part: every repeated field reached through singular fields, from 0.
void collect_ranges(const pb::Message& m, const std::string& prefix, Part& part) {
  std::vector<const pb::FieldDescriptor*> fields;
  m.GetReflection()->ListFields(m, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    const std::string key = prefix.empty() ? f->name() : prefix + "." + f->name();
    if (f->is_repeated()) {
      part.ranges[key] = {0, m.GetReflection()->FieldSize(m, f)};
    } else if (f->message_type() != nullptr) {
      collect_ranges(m.GetReflection()->GetMessage(m, f), key, part);
    }
  }
}

// The size of the repeated field at `key` ("dds.bridges") in `m`; 0 where a message on the way is unset.
int size_at(const pb::Message& m, std::string_view key) {
  const pb::Message* at = &m;
  while (true) {
    const std::size_t dot = key.find('.');
    const pb::FieldDescriptor* f = at->GetDescriptor()->FindFieldByName(std::string(key.substr(0, dot)));
    if (f == nullptr) {
      return 0;
    }
    if (dot == std::string_view::npos) {
      return f->is_repeated() ? at->GetReflection()->FieldSize(*at, f) : 0;
    }
    if (f->is_repeated() || f->message_type() == nullptr || !at->GetReflection()->HasField(*at, f)) {
      return 0;
    }
    at = &at->GetReflection()->GetMessage(*at, f);
    key.remove_prefix(dot + 1);
  }
}

}  // namespace

struct TextLocations::Impl {
  const pb::Descriptor* root = nullptr;
  std::vector<Part> parts;  // merge order: fragments first, the root file last
};

TextLocations::TextLocations(std::string file, std::unique_ptr<Impl> impl)
    : file_(std::move(file)), impl_(std::move(impl)) {}
TextLocations::TextLocations(TextLocations&&) noexcept = default;
TextLocations& TextLocations::operator=(TextLocations&&) noexcept = default;
TextLocations::~TextLocations() = default;

SourceLocation TextLocations::locate(std::initializer_list<Step> path, std::string_view field, int index) const {
  return locate(std::span<const Step>(path.begin(), path.size()), field, index);
}

SourceLocation TextLocations::locate(std::span<const Step> path, std::string_view field, int index) const {
  Found best{file_only(), 0, false};
  // Later parts override earlier ones: a tie goes to the later (the including file is last).
  for (const Part& part : impl_->parts) {
    const Found f = locate_in(part, impl_->root, path, field, index);
    if (f.depth > 0 && f.depth >= best.depth) {
      best = f;
    }
  }
  return best.where;
}

bool TextLocations::written(std::span<const Step> path, std::string_view field, int index) const {
  return std::any_of(impl_->parts.begin(), impl_->parts.end(), [&](const Part& part) {
    return locate_in(part, impl_->root, path, field, index).exact;
  });
}

std::vector<std::string> TextLocations::files() const {
  std::vector<std::string> out;
  for (const Part& part : impl_->parts) {
    if (std::find(out.begin(), out.end(), part.file) == out.end()) {
      out.push_back(part.file);
    }
  }
  return out;
}

namespace {

// Collects the first error the parser reports, with its 1-based position.
class FirstErrorCollector final : public pb::io::ErrorCollector {
 public:
  void AddError(int line, pb::io::ColumnNumber column, const std::string& message) override {
    if (!error_) {
      error_ = std::make_pair(SourceLocation{"", line + 1, column + 1}, message);
    }
  }
  void AddWarning(int line, pb::io::ColumnNumber column, const std::string& message) override {
    AddError(line, column, message);  // text-format warnings are about ignored input: refuse it
  }
  [[nodiscard]] const std::optional<std::pair<SourceLocation, std::string>>& first() const { return error_; }

 private:
  std::optional<std::pair<SourceLocation, std::string>> error_;
};

// protobuf reports an unknown field or enum value after the token; point at the token itself, which the
// message names in quotes ("... has no field named \"bogus\"").
void point_at_named_token(std::string_view text, std::string_view message, SourceLocation& where) {
  const std::size_t open = message.rfind("named \"");
  const std::size_t enum_value = message.find("value of \"");  // "Unknown enumeration value of \"X\" for field …"
  const std::size_t quote = open != std::string_view::npos         ? open
                            : enum_value != std::string_view::npos ? enum_value
                                                                   : message.rfind("value \"");
  if (quote == std::string_view::npos || where.line <= 0) {
    return;
  }
  const std::size_t start = message.find('"', quote) + 1;
  const std::size_t end = message.find('"', start);
  if (end == std::string_view::npos) {
    return;
  }
  const std::string_view token = message.substr(start, end - start);
  if (token.empty()) return;
  // The line protobuf reported, then the lines before it (an enum value at the end of a line is reported at the
  // next token, which may be lines further on).
  for (int line_no = where.line; line_no >= 1 && line_no >= where.line - 8; --line_no) {
    std::size_t line_start = 0;
    for (int line = 1; line < line_no && line_start != std::string_view::npos; ++line) {
      line_start = text.find('\n', line_start);
      line_start = line_start == std::string_view::npos ? line_start : line_start + 1;
    }
    if (line_start == std::string_view::npos) continue;
    const std::string_view line = text.substr(line_start, text.find('\n', line_start) - line_start);
    const std::size_t before =
        line_no == where.line ? std::min<std::size_t>(line.size(), static_cast<std::size_t>(where.column)) : line.size();
    const std::size_t at = line.substr(0, before).rfind(token);
    if (at != std::string_view::npos) {
      where.line = line_no;
      where.column = static_cast<int>(at) + 1;
      return;
    }
  }
}

}  // namespace

// ---- Gates: what is not a text file of the expected kind is refused by name, without its content ----

namespace {

// Where a file stops being UTF-8 text (1-based line and column, in characters), and why; nullopt when it is.
// Text is UTF-8 without NUL or another control character but tab, line feed and carriage return.
struct NotText {
  int line = 0;
  int column = 0;
  std::string_view what;
};

std::optional<NotText> find_non_text(std::string_view text) {
  int line = 1;
  int column = 1;
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++line;
      column = 1;
      ++i;
      continue;
    }
    if (c == 0) return NotText{line, column, "a NUL byte"};
    if (c < 0x80) {
      if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7F) return NotText{line, column, "a control character"};
      ++column;
      ++i;
      continue;
    }
    // A multi-byte sequence (RFC 3629 §4): lead byte, continuation bytes, no overlong form, no surrogate,
    // nothing past U+10FFFF.
    const std::size_t length = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
    if (length == 0 || i + length > text.size()) return NotText{line, column, "a byte that is not UTF-8"};
    std::uint32_t code = c & (0x7FU >> length);
    for (std::size_t k = 1; k < length; ++k) {
      const auto cont = static_cast<unsigned char>(text[i + k]);
      if ((cont & 0xC0U) != 0x80U) return NotText{line, column, "a byte that is not UTF-8"};
      code = (code << 6U) | (cont & 0x3FU);
    }
    constexpr std::array<std::uint32_t, 5> kLeast{0, 0, 0x80, 0x800, 0x10000};
    if (code < kLeast[length] || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) {
      return NotText{line, column, "a byte that is not UTF-8"};
    }
    if (code >= 0x80 && code <= 0x9F) return NotText{line, column, "a control character"};
    ++column;
    i += length;
  }
  return std::nullopt;
}

class IgnoreErrors final : public pb::io::ErrorCollector {
 public:
  void AddError(int /*line*/, pb::io::ColumnNumber /*column*/, const std::string& /*message*/) override {}
};

// Whether the file's first word (after comments and blanks) is a field of `type`, or the file has no word at
// all; if not, where that word is (0-based, as protobuf's tokenizer counts).
std::optional<std::pair<int, int>> first_word_not_a_field(std::string_view text, const pb::Descriptor& type) {
  pb::io::ArrayInputStream in(text.data(), static_cast<int>(text.size()));
  IgnoreErrors ignore;
  pb::io::Tokenizer tokenizer(&in, &ignore);
  tokenizer.set_comment_style(pb::io::Tokenizer::SH_COMMENT_STYLE);  // text format's `#` comments
  if (!tokenizer.Next()) {
    return std::nullopt;  // empty, or comments only
  }
  const pb::io::Tokenizer::Token& first = tokenizer.current();
  if (first.type == pb::io::Tokenizer::TYPE_IDENTIFIER && type.FindFieldByName(first.text) != nullptr) {
    return std::nullopt;
  }
  return std::make_pair(first.line, static_cast<int>(first.column));
}

// The two gates every file passes before its text is parsed: UTF-8 text, and a first word that is a field of
// the expected message. The refusal says where, never what the file holds there.
std::optional<std::pair<SourceLocation, std::string>> refuse_by_kind(std::string_view text, const std::string& name,
                                                                     const pb::Descriptor& type) {
  if (const auto bad = find_non_text(text)) {
    return std::make_pair(SourceLocation{name, bad->line, bad->column},
                          "not a text file (" + std::string(bad->what) + " at line " + std::to_string(bad->line) +
                              ", column " + std::to_string(bad->column) + ")");
  }
  if (const auto at = first_word_not_a_field(text, type)) {
    const int line = at->first + 1;
    const int column = at->second + 1;
    return std::make_pair(SourceLocation{name, line, column},
                          "not a " + type.name() + " file (its first word, at line " + std::to_string(line) +
                              ", column " + std::to_string(column) + ", is no field of " + type.full_name() + ")");
  }
  return std::nullopt;
}

// protobuf's message for a syntax error, without the text of the file it was found in: what the parser
// expected when it names a token class or one punctuation mark, else only the class of error. Every word kept
// comes from the schema or from this table, none from the file.
std::string without_file_text(std::string_view message) {
  constexpr std::string_view kNote = " (an included file's text is not quoted)";
  const auto starts = [&](std::string_view prefix) { return message.rfind(prefix, 0) == 0; };
  if (starts("Message type \"") && message.find("\" has no field named") != std::string_view::npos) {
    const std::size_t end = message.find('"', 14);
    return "no such field in " + std::string(message.substr(14, end - 14)) + std::string(kNote);
  }
  if (starts("Unknown enumeration value")) return "unknown enumeration value" + std::string(kNote);
  if (starts("Expected ")) {
    const std::size_t end = message.find(", ");
    const std::string_view expected = message.substr(9, end == std::string_view::npos ? 0 : end - 9);
    constexpr std::array<std::string_view, 6> kClasses{"identifier", "integer", "double", "string", "value",
                                                       "bool"};
    const bool punctuation = expected.size() == 3 && expected.front() == '"' && expected.back() == '"' &&
                             std::ispunct(static_cast<unsigned char>(expected[1])) != 0;
    if (punctuation || std::find(kClasses.begin(), kClasses.end(), expected) != kClasses.end()) {
      return "expected " + std::string(expected) + std::string(kNote);
    }
    return "unexpected text" + std::string(kNote);
  }
  if (message.find("specified multiple times") != std::string_view::npos) {
    return "a singular field is set twice" + std::string(kNote);
  }
  if (message.find("oneof") != std::string_view::npos) return "two members of one oneof are set" + std::string(kNote);
  if (message.find("out of range") != std::string_view::npos) return "a number out of range" + std::string(kNote);
  return "not valid text format here" + std::string(kNote);
}

// protobuf's "Message type \"T\" has no field named \"x\"." with the field of T that x most likely meant (the
// schema knows every field: rejuv/core/did_you_mean.hpp). Unchanged for any other message.
std::string with_field_suggestion(std::string message, const pb::Descriptor& root) {
  constexpr std::string_view kType = "Message type \"";
  constexpr std::string_view kField = "\" has no field named \"";
  if (message.rfind(kType, 0) != 0) return message;
  const std::size_t type_end = message.find(kField);
  if (type_end == std::string::npos) return message;
  const std::size_t name_start = type_end + kField.size();
  const std::size_t name_end = message.find('"', name_start);
  if (name_end == std::string::npos) return message;
  const std::string type = message.substr(kType.size(), type_end - kType.size());
  const pb::Descriptor* d = root.file()->pool()->FindMessageTypeByName(type);
  if (d == nullptr) return message;
  std::vector<std::string> fields;
  for (int i = 0; i < d->field_count(); ++i) fields.push_back(d->field(i)->name());
  const std::string hint = did_you_mean(std::string_view(message).substr(name_start, name_end - name_start), fields);
  if (hint.empty()) return message;
  if (message.ends_with(".")) message.pop_back();
  return message + hint;
}

// protobuf's "Unknown enumeration value of \"X\" for field \"f\"." with the value X most likely meant: the values of
// every enum field named f in the messages reachable from `root`. Unchanged for any other message.
std::string with_enum_suggestion(std::string message, const pb::Descriptor& root) {
  constexpr std::string_view kValue = "Unknown enumeration value of \"";
  constexpr std::string_view kField = "\" for field \"";
  if (message.rfind(kValue, 0) != 0) return message;
  const std::size_t value_end = message.find(kField, kValue.size());
  if (value_end == std::string::npos) return message;
  const std::size_t field_end = message.find('"', value_end + kField.size());
  if (field_end == std::string::npos) return message;
  const std::string value = message.substr(kValue.size(), value_end - kValue.size());
  const std::string field = message.substr(value_end + kField.size(), field_end - value_end - kField.size());
  std::vector<std::string> names;
  std::vector<const pb::Descriptor*> todo{&root};
  std::vector<const pb::Descriptor*> seen;
  while (!todo.empty()) {
    const pb::Descriptor* d = todo.back();
    todo.pop_back();
    if (std::find(seen.begin(), seen.end(), d) != seen.end()) continue;
    seen.push_back(d);
    for (int i = 0; i < d->field_count(); ++i) {
      const pb::FieldDescriptor* f = d->field(i);
      if (f->message_type() != nullptr) todo.push_back(f->message_type());
      if (f->enum_type() == nullptr || f->name() != field) continue;
      for (int v = 0; v < f->enum_type()->value_count(); ++v) names.push_back(f->enum_type()->value(v)->name());
    }
  }
  const std::string hint = did_you_mean(value, names);
  if (hint.empty()) return message;
  if (message.ends_with(".")) message.pop_back();
  return message + hint;
}

// The innermost block still open at the end of the text (`name {` or `name <` without its closing mark), as
// protobuf's tokenizer reads it (comments and strings skipped): its field name and 1-based position.
struct OpenBlock {
  std::string field;
  int line = 0;
  int column = 0;
  char close = '}';
};
std::optional<OpenBlock> unclosed_block(std::string_view text) {
  pb::io::ArrayInputStream in(text.data(), static_cast<int>(text.size()));
  IgnoreErrors ignore;
  pb::io::Tokenizer tokenizer(&in, &ignore);
  tokenizer.set_comment_style(pb::io::Tokenizer::SH_COMMENT_STYLE);
  std::vector<OpenBlock> open;
  std::string previous;
  while (tokenizer.Next()) {
    const pb::io::Tokenizer::Token& t = tokenizer.current();
    if (t.type == pb::io::Tokenizer::TYPE_SYMBOL && (t.text == "{" || t.text == "<")) {
      open.push_back(OpenBlock{previous, t.line + 1, static_cast<int>(t.column) + 1, t.text == "{" ? '}' : '>'});
    } else if (t.type == pb::io::Tokenizer::TYPE_SYMBOL && (t.text == "}" || t.text == ">") && !open.empty()) {
      open.pop_back();
    }
    previous = t.type == pb::io::Tokenizer::TYPE_IDENTIFIER ? t.text : std::string();
  }
  if (open.empty()) return std::nullopt;
  return open.back();
}

// protobuf's "Expected identifier, got: " at the end of the text, said as what it is: a block never closed, and
// where it began. `name_it`: whether the block's field name may be quoted (not from an included file's text).
std::optional<std::string> missing_close(std::string_view text, std::string_view message, bool name_it) {
  if (!message.starts_with("Expected identifier, got: ") || message.size() != 26) return std::nullopt;
  const auto block = unclosed_block(text);
  if (!block) return std::nullopt;
  std::string out = std::string("missing '") + block->close + "' at the end of the file: the block ";
  if (name_it && !block->field.empty()) out += "`" + block->field + " " + (block->close == '}' ? "{" : "<") + "` ";
  return out + "opened at line " + std::to_string(block->line) + ", column " + std::to_string(block->column) +
         " is never closed";
}

// Whether a syntax error may quote the file's text: yes for the file the user named, no for a file it includes
// (its path was written by whoever wrote the including file, and may name a file that user could not read).
enum class Quoting : std::uint8_t { FileText, NothingFromTheFile };

Result<TextLocations, LoadError> parse_one(std::string_view text, std::string name, pb::Message& out,
                                           Quoting quoting) {
  out.Clear();
  if (text.size() > kMaxTextprotoBytes) {
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{name, 1, 1},
                          "file is larger than " + std::to_string(kMaxTextprotoBytes) + " bytes"});
  }
  if (auto refused = refuse_by_kind(text, name, *out.GetDescriptor())) {
    return fail(LoadError{LoadErrorKind::Syntax, std::move(refused->first), std::move(refused->second)});
  }
  FirstErrorCollector errors;
  auto impl = std::make_unique<TextLocations::Impl>();
  impl->root = out.GetDescriptor();
  Part part{name, std::make_unique<pb::TextFormat::ParseInfoTree>(), {}};
  pb::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(part.tree.get());
  parser.AllowPartialMessage(false);
  const bool ok = parser.ParseFromString(std::string(text), &out);
  if (!ok || errors.first()) {
    SourceLocation where{name, 0, 0};
    std::string message = "cannot parse";
    if (errors.first()) {
      where.line = errors.first()->first.line;
      where.column = errors.first()->first.column;
      message = errors.first()->second;
    }
    out.Clear();
    point_at_named_token(text, message, where);
    if (auto unclosed = missing_close(text, message, quoting == Quoting::FileText)) {
      message = std::move(*unclosed);
    } else if (quoting == Quoting::NothingFromTheFile) {
      message = without_file_text(message);
    } else {
      message = with_enum_suggestion(with_field_suggestion(std::move(message), *out.GetDescriptor()),
                                     *out.GetDescriptor());
    }
    return fail(LoadError{LoadErrorKind::Syntax, std::move(where), std::move(message)});
  }
  collect_ranges(out, "", part);
  impl->parts.push_back(std::move(part));
  return TextLocations(std::move(name), std::move(impl));
}

// The text of a file, or why it cannot be read (sys::read_regular_file: no FIFO, device or directory is opened).
Result<std::string, LoadError> read_text(const std::filesystem::path& path) {
  auto text = sys::read_regular_file(path, kMaxTextprotoBytes);
  if (!text) {
    // At 1:1: the refusal is of the whole file, and every error has a file:line:column (README, exit 2).
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{path.string(), 1, 1},
                          text.error().to_string(kMaxTextprotoBytes)});
  }
  return std::move(*text);
}

}  // namespace

Result<TextLocations, LoadError> parse_textproto(std::string_view text, std::string name, pb::Message& out) {
  return parse_one(text, std::move(name), out, Quoting::FileText);
}

Result<TextLocations, LoadError> load_textproto(const std::filesystem::path& path, pb::Message& out) {
  auto text = read_text(path);
  if (!text) {
    out.Clear();
    return fail(std::move(text.error()));
  }
  return parse_textproto(*text, path.string(), out);
}


// ---- Composition ----

namespace {

void copy_scalar(const pb::Message& src, pb::Message& dst, const pb::FieldDescriptor* f) {
  const pb::Reflection* s = src.GetReflection();
  const pb::Reflection* d = dst.GetReflection();
  switch (f->cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_INT32: d->SetInt32(&dst, f, s->GetInt32(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_INT64: d->SetInt64(&dst, f, s->GetInt64(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_UINT32: d->SetUInt32(&dst, f, s->GetUInt32(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_UINT64: d->SetUInt64(&dst, f, s->GetUInt64(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_DOUBLE: d->SetDouble(&dst, f, s->GetDouble(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_FLOAT: d->SetFloat(&dst, f, s->GetFloat(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_BOOL: d->SetBool(&dst, f, s->GetBool(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_ENUM: d->SetEnumValue(&dst, f, s->GetEnumValue(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_STRING: d->SetString(&dst, f, s->GetString(src, f)); break;
    case pb::FieldDescriptor::CPPTYPE_MESSAGE: d->MutableMessage(&dst, f)->CopyFrom(s->GetMessage(src, f)); break;
  }
}

void append_repeated(const pb::Message& src, pb::Message& dst, const pb::FieldDescriptor* f) {
  const pb::Reflection* s = src.GetReflection();
  const pb::Reflection* d = dst.GetReflection();
  for (int k = 0; k < s->FieldSize(src, f); ++k) {
    switch (f->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_INT32: d->AddInt32(&dst, f, s->GetRepeatedInt32(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_INT64: d->AddInt64(&dst, f, s->GetRepeatedInt64(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_UINT32: d->AddUInt32(&dst, f, s->GetRepeatedUInt32(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_UINT64: d->AddUInt64(&dst, f, s->GetRepeatedUInt64(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_DOUBLE: d->AddDouble(&dst, f, s->GetRepeatedDouble(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_FLOAT: d->AddFloat(&dst, f, s->GetRepeatedFloat(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_BOOL: d->AddBool(&dst, f, s->GetRepeatedBool(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_ENUM: d->AddEnumValue(&dst, f, s->GetRepeatedEnumValue(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_STRING: d->AddString(&dst, f, s->GetRepeatedString(src, f, k)); break;
      case pb::FieldDescriptor::CPPTYPE_MESSAGE:
        d->AddMessage(&dst, f)->CopyFrom(s->GetRepeatedMessage(src, f, k));
        break;
    }
  }
}

std::string dotted(std::span<const TextLocations::Step> path, std::string_view field) {
  std::string out;
  for (const TextLocations::Step& s : path) {
    out += std::string(s.field) + ".";
  }
  return out + std::string(field);
}

// The `include` field of a message type that can be composed, or nullptr.
const pb::FieldDescriptor* include_field(const pb::Descriptor* d) {
  const pb::FieldDescriptor* f = d->FindFieldByName("include");
  return f != nullptr && f->is_repeated() && f->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING ? f : nullptr;
}

std::string canonical_name(const std::filesystem::path& p) {
  std::error_code ec;
  const std::filesystem::path c = std::filesystem::weakly_canonical(p, ec);
  return (ec ? p.lexically_normal() : c).string();
}

}  // namespace

// Composes a file from its fragments (textproto.hpp "Composition"); one per load, it remembers the files
// being composed (cycles) and those already merged (a file included twice).
class Composer {
 public:
  explicit Composer(const std::filesystem::path& root) : stack_{canonical_name(root)}, seen_{{stack_[0], "the root"}} {}

  Result<TextLocations, LoadError> compose(std::string_view text, const std::filesystem::path& file,
                                           pb::Message& out, std::span<const ExtraFragment> extra, int depth) {
    ++files_;
    std::unique_ptr<pb::Message> own(out.New());
    // An included file's syntax errors never quote its text (textproto.hpp "What is refused").
    auto own_locs = parse_one(text, file.string(), *own, depth == 0 ? Quoting::FileText : Quoting::NothingFromTheFile);
    if (!own_locs) {
      out.Clear();
      return fail(std::move(own_locs.error()));
    }
    out.Clear();
    auto impl = std::make_unique<TextLocations::Impl>();
    impl->root = out.GetDescriptor();
    TextLocations merged(file.string(), std::move(impl));
    std::vector<ExtraFragment> fragments(extra.begin(), extra.end());
    const pb::FieldDescriptor* include = include_field(out.GetDescriptor());
    if (include != nullptr) {
      for (int i = 0; i < own->GetReflection()->FieldSize(*own, include); ++i) {
        const std::filesystem::path named(own->GetReflection()->GetRepeatedString(*own, include, i));
        fragments.push_back(ExtraFragment{named.is_relative() ? file.parent_path() / named : named,
                                          own_locs->locate({}, "include", i)});
      }
    }
    for (const ExtraFragment& fragment : fragments) {
      auto sub = include_one(fragment, out, depth);
      if (!sub) {
        out.Clear();
        return fail(std::move(sub.error()));
      }
      if (auto m = merge(out, merged, *sub->first, std::move(sub->second), false); !m) {
        out.Clear();
        return fail(std::move(m.error()));
      }
    }
    if (auto m = merge(out, merged, *own, std::move(*own_locs), true); !m) {
      out.Clear();
      return fail(std::move(m.error()));
    }
    if (include != nullptr) {
      out.GetReflection()->ClearField(&out, include);
    }
    return merged;
  }

 private:
  using Composed = std::pair<std::unique_ptr<pb::Message>, TextLocations>;

  Result<Composed, LoadError> include_one(const ExtraFragment& fragment, const pb::Message& like, int depth) {
    const SourceLocation& at = fragment.named_at;
    const std::string shown = fragment.path.lexically_normal().string();
    if (depth + 1 > kMaxIncludeDepth) {
      return fail(semantic_error(at, "cannot include \"" + shown + "\": includes nest deeper than " +
                                         std::to_string(kMaxIncludeDepth) + " files"));
    }
    if (files_ >= kMaxComposedFiles) {
      return fail(semantic_error(at, "cannot include \"" + shown + "\": more than " +
                                         std::to_string(kMaxComposedFiles) + " files in one composition"));
    }
    const std::string canonical = canonical_name(fragment.path);
    if (std::find(stack_.begin(), stack_.end(), canonical) != stack_.end()) {
      std::string chain;
      for (const std::string& s : stack_) {
        chain += s + " → ";
      }
      return fail(semantic_error(at, "include cycle: " + chain + canonical));
    }
    if (const auto it = seen_.find(canonical); it != seen_.end()) {
      return fail(semantic_error(at, "\"" + shown + "\" is already included (by " + it->second +
                                         "): include each file once"));
    }
    auto text = read_text(fragment.path);
    if (!text) {
      return fail(semantic_error(at, "cannot include \"" + shown + "\": " + text.error().message));
    }
    if (auto refused = refuse_by_kind(*text, shown, *like.GetDescriptor())) {
      return fail(semantic_error(at, "cannot include \"" + shown + "\": " + refused->second));
    }
    seen_.emplace(canonical, at.to_string());
    stack_.push_back(canonical);
    std::unique_ptr<pb::Message> sub(like.New());
    auto locs = compose(*text, fragment.path.lexically_normal(), *sub, {}, depth + 1);
    stack_.pop_back();
    if (!locs) {
      return fail(std::move(locs.error()));
    }
    return Composed{std::move(sub), std::move(*locs)};
  }

  // Merges `src` (read from `src_locs`) into `dst`; with `override_`, src's singular fields replace dst's,
  // without, a field both set is refused at src's place.
  static Result<void, LoadError> merge(pb::Message& dst, TextLocations& dst_locs, const pb::Message& src,
                                       TextLocations src_locs, bool override_) {
    std::vector<TextLocations::Step> path;
    if (auto m = merge_fields(dst, dst_locs, src, src_locs, path, override_); !m) {
      return m;
    }
    // The elements src appended follow those dst held before: shift src's ranges by that many.
    for (Part& part : src_locs.impl_->parts) {
      for (auto& [key, range] : part.ranges) {
        range.first += size_at(dst, key) - size_at(src, key);
      }
      dst_locs.impl_->parts.push_back(std::move(part));
    }
    return {};
  }

  static Result<void, LoadError> merge_fields(pb::Message& dst, const TextLocations& dst_locs, const pb::Message& src,
                                              const TextLocations& src_locs, std::vector<TextLocations::Step>& path,
                                              bool override_) {
    const pb::Descriptor* desc = src.GetDescriptor();
    const pb::Reflection* s = src.GetReflection();
    const pb::Reflection* d = dst.GetReflection();
    for (int i = 0; i < desc->field_count(); ++i) {
      const pb::FieldDescriptor* f = desc->field(i);
      if (path.empty() && f == include_field(desc)) {
        continue;  // composed already
      }
      if (f->is_repeated()) {
        append_repeated(src, dst, f);
        continue;
      }
      if (f->message_type() != nullptr && f->containing_oneof() == nullptr) {
        if (!s->HasField(src, f)) {
          continue;
        }
        if (!d->HasField(dst, f)) {
          d->MutableMessage(&dst, f)->CopyFrom(s->GetMessage(src, f));
          continue;
        }
        path.push_back(TextLocations::Step{f->name(), -1});
        auto m = merge_fields(*d->MutableMessage(&dst, f), dst_locs, s->GetMessage(src, f), src_locs, path, override_);
        path.pop_back();
        if (!m) {
          return m;
        }
        continue;
      }
      if (!src_locs.written(path, f->name())) {
        continue;
      }
      // The field dst already has: this one, or another member of its oneof.
      const pb::FieldDescriptor* held = f;
      if (const pb::OneofDescriptor* o = f->containing_oneof(); o != nullptr && d->HasOneof(dst, o)) {
        held = d->GetOneofFieldDescriptor(dst, o);
      }
      if (!override_ && dst_locs.written(path, held->name())) {
        return fail(semantic_error(src_locs.locate(path, f->name()),
                                   "`" + dotted(path, f->name()) + "` is set here and at " +
                                       dst_locs.locate(path, held->name()).to_string() +
                                       ": set it in one of them, or in the file that includes both"));
      }
      copy_scalar(src, dst, f);
    }
    return {};
  }

  std::vector<std::string> stack_;           // canonical names of the files being composed, root first
  std::map<std::string, std::string> seen_;  // canonical name → where it was included
  int files_ = 0;
};

Result<TextLocations, LoadError> parse_composed_textproto(std::string_view text, std::string name, pb::Message& out,
                                                          std::span<const ExtraFragment> extra) {
  if (text.size() > kMaxTextprotoBytes) {
    return parse_textproto(text, std::move(name), out);  // the size error
  }
  const std::filesystem::path file(name);
  return Composer(file).compose(text, file, out, extra, 0);
}

Result<TextLocations, LoadError> load_composed_textproto(const std::filesystem::path& path, pb::Message& out,
                                                         std::span<const ExtraFragment> extra) {
  auto text = read_text(path);
  if (!text) {
    out.Clear();
    return fail(std::move(text.error()));
  }
  return Composer(path).compose(*text, path, out, extra, 0);
}

}  // namespace rejuv
