#include "rejuv/textproto/textproto.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/message.h>
#include <google/protobuf/text_format.h>

#include <fstream>
#include <algorithm>
#include <optional>
#include <sstream>
#include <system_error>

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

struct TextLocations::Impl {
  const pb::Descriptor* root;
  pb::TextFormat::ParseInfoTree tree;
};

TextLocations::TextLocations(std::string file, std::unique_ptr<Impl> impl)
    : file_(std::move(file)), impl_(std::move(impl)) {}
TextLocations::TextLocations(TextLocations&&) noexcept = default;
TextLocations& TextLocations::operator=(TextLocations&&) noexcept = default;
TextLocations::~TextLocations() = default;

SourceLocation TextLocations::locate(std::initializer_list<Step> path, std::string_view field,
                                     int index) const {
  SourceLocation best = file_only();
  const pb::Descriptor* desc = impl_->root;
  const pb::TextFormat::ParseInfoTree* tree = &impl_->tree;
  const auto remember = [&](const pb::FieldDescriptor* f, int i) {
    const pb::TextFormat::ParseLocation loc = tree->GetLocation(f, i);
    if (loc.line >= 0) {
      best = SourceLocation{file_, loc.line + 1, loc.column + 1};
    }
  };
  for (const Step& step : path) {
    const pb::FieldDescriptor* f = desc->FindFieldByName(std::string(step.field));
    if (f == nullptr || f->message_type() == nullptr || tree == nullptr) {
      return best;
    }
    remember(f, step.index);
    tree = tree->GetTreeForNested(f, step.index);
    desc = f->message_type();
  }
  if (tree == nullptr) {
    return best;
  }
  if (const pb::FieldDescriptor* f = desc->FindFieldByName(std::string(field)); f != nullptr) {
    remember(f, index);
  }
  return best;
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
  const std::size_t quote = open == std::string_view::npos ? message.rfind("value \"") : open;
  if (quote == std::string_view::npos || where.line <= 0) {
    return;
  }
  const std::size_t start = message.find('"', quote) + 1;
  const std::size_t end = message.find('"', start);
  if (end == std::string_view::npos) {
    return;
  }
  const std::string_view token = message.substr(start, end - start);
  std::size_t line_start = 0;
  for (int line = 1; line < where.line && line_start != std::string_view::npos; ++line) {
    line_start = text.find('\n', line_start);
    line_start = line_start == std::string_view::npos ? line_start : line_start + 1;
  }
  if (line_start == std::string_view::npos) {
    return;
  }
  const std::string_view line = text.substr(line_start, text.find('\n', line_start) - line_start);
  const std::size_t before = std::min<std::size_t>(line.size(), static_cast<std::size_t>(where.column));
  const std::size_t at = line.substr(0, before).rfind(token);
  if (at != std::string_view::npos && !token.empty()) {
    where.column = static_cast<int>(at) + 1;
  }
}

}  // namespace

Result<TextLocations, LoadError> parse_textproto(std::string_view text, std::string name, pb::Message& out) {
  out.Clear();
  if (text.size() > kMaxTextprotoBytes) {
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{name, 0, 0},
                          "file is larger than " + std::to_string(kMaxTextprotoBytes) + " bytes"});
  }
  FirstErrorCollector errors;
  auto impl = std::make_unique<TextLocations::Impl>();
  impl->root = out.GetDescriptor();
  pb::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(&impl->tree);
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
    return fail(LoadError{LoadErrorKind::Syntax, std::move(where), std::move(message)});
  }
  return TextLocations(std::move(name), std::move(impl));
}

Result<TextLocations, LoadError> load_textproto(const std::filesystem::path& path, pb::Message& out) {
  const std::string name = path.string();
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{name, 0, 0}, "no such file"});
  }
  if (!std::filesystem::is_regular_file(status)) {
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{name, 0, 0}, "not a regular file"});
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxTextprotoBytes) {
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{name, 0, 0},
                          ec ? "cannot read: " + ec.message()
                             : "file is larger than " + std::to_string(kMaxTextprotoBytes) + " bytes"});
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return fail(LoadError{LoadErrorKind::CannotRead, SourceLocation{name, 0, 0}, "cannot open for reading"});
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return parse_textproto(buffer.str(), name, out);
}

}  // namespace rejuv
