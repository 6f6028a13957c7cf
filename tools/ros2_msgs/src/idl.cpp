#include "rejuv/ros2_msgs/idl.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

namespace rejuv::ros2_msgs {

std::string IdlError::to_string() const {
  if (at.line == 0) return at.file + ": error: " + message;  // a file as a whole (named on the command line)
  return at.file + ":" + std::to_string(at.line) + ":" + std::to_string(at.column) + ": error: " + message;
}

const Struct* Definitions::find_struct(std::string_view scoped_name) const {
  for (const Struct& s : structs) {
    if (s.scoped_name == scoped_name) return &s;
  }
  return nullptr;
}

const Enum* Definitions::find_enum(std::string_view scoped_name) const {
  for (const Enum& e : enums) {
    if (e.scoped_name == scoped_name) return &e;
  }
  return nullptr;
}

namespace {

// ---- lexer ----

struct Token {
  enum class Kind : std::uint8_t { Ident, Number, Punct, String, Directive, End };
  Kind kind = Kind::End;
  std::string text;
  SourcePos at;
};

// A `//` comment: where it starts and whether code precedes it on its line.
struct Comment {
  int line = 0;
  int column = 0;
  bool trailing = false;
  std::string text;
};

struct Lexed {
  std::vector<Token> tokens;
  std::vector<Comment> comments;
};

std::unexpected<IdlError> error_at(const SourcePos& at, std::string message) {
  return std::unexpected(IdlError{.at = at, .message = std::move(message)});
}

bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0 || c == '_'; }
bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; }

std::string trim(std::string_view s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b])) != 0) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1])) != 0) --e;
  return std::string(s.substr(b, e - b));
}

// The end of the run of characters from `i` that `keep` accepts.
template <class Keep>
std::size_t run_end(std::string_view text, std::size_t i, Keep keep) {
  while (i < text.size() && keep(text[i])) ++i;
  return i;
}

Result<Lexed, IdlError> lex(std::string_view text, const std::string& file) {
  Lexed out;
  std::size_t i = 0;
  int line = 1;
  std::size_t line_start = 0;
  bool code_on_line = false;
  const auto pos = [&](std::size_t at) {
    return SourcePos{.file = file, .line = line, .column = static_cast<int>(at - line_start) + 1};
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = ++i;
      code_on_line = false;
      continue;
    }
    if (std::isspace(static_cast<unsigned char>(c)) != 0) {
      ++i;
      continue;
    }
    if (text.substr(i, 2) == "//") {
      const std::size_t end = std::min(text.find('\n', i), text.size());
      const SourcePos at = pos(i);
      out.comments.push_back(
          Comment{.line = at.line, .column = at.column, .trailing = code_on_line, .text = trim(text.substr(i + 2, end - i - 2))});
      i = end;
      continue;
    }
    if (text.substr(i, 2) == "/*") {
      const SourcePos at = pos(i);
      const std::size_t end = text.find("*/", i + 2);
      if (end == std::string_view::npos) return error_at(at, "unterminated /* comment");
      const std::string_view body = text.substr(i, end - i);
      line += static_cast<int>(std::count(body.begin(), body.end(), '\n'));
      if (const std::size_t nl = text.rfind('\n', end); nl != std::string_view::npos && nl >= i) line_start = nl + 1;
      i = end + 2;
      continue;
    }
    const SourcePos at = pos(i);
    if (c == '#' && !code_on_line) {
      const std::size_t end = std::min(text.find('\n', i), text.size());
      out.tokens.push_back(Token{.kind = Token::Kind::Directive, .text = trim(text.substr(i, end - i)), .at = at});
      i = end;
      continue;
    }
    code_on_line = true;
    if (ident_start(c)) {
      const std::size_t e = run_end(text, i, ident_char);
      out.tokens.push_back(Token{.kind = Token::Kind::Ident, .text = std::string(text.substr(i, e - i)), .at = at});
      i = e;
      continue;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) != 0) {
      const std::size_t e = run_end(text, i, [](char d) { return ident_char(d) || d == '.'; });
      out.tokens.push_back(Token{.kind = Token::Kind::Number, .text = std::string(text.substr(i, e - i)), .at = at});
      i = e;
      continue;
    }
    if (c == '"') {
      const std::size_t end = text.find_first_of("\"\n", i + 1);
      if (end == std::string_view::npos || text[end] != '"') return error_at(at, "unterminated string literal");
      out.tokens.push_back(Token{.kind = Token::Kind::String, .text = std::string(text.substr(i + 1, end - i - 1)), .at = at});
      i = end + 1;
      continue;
    }
    const std::size_t punct = text.substr(i, 2) == "::"                                                     ? 2
                              : std::string_view("{}[];,<>()=@:-+*/|&^~%'").find(c) != std::string_view::npos ? 1
                                                                                                          : 0;
    if (punct > 0) {
      out.tokens.push_back(Token{.kind = Token::Kind::Punct, .text = std::string(text.substr(i, punct)), .at = at});
      i += punct;
      continue;
    }
    return error_at(at, std::string("unexpected character '") + c + "'");
  }
  out.tokens.push_back(Token{.kind = Token::Kind::End, .text = "end of file", .at = pos(i)});
  return out;
}

// ---- parser ----

// IDL constructs outside the subset, each with why the generator refuses it.
struct Unsupported {
  std::string_view keyword;
  std::string_view what;
};
constexpr std::array kUnsupported{
    Unsupported{"sequence", "sequence<T> (a variable-length member)"},
    Unsupported{"string", "string (a variable-length member)"},
    Unsupported{"wstring", "wstring (a variable-length member)"},
    Unsupported{"wchar", "wchar"},
    Unsupported{"union", "union"},
    Unsupported{"typedef", "typedef"},
    Unsupported{"const", "const"},
    Unsupported{"bitset", "bitset"},
    Unsupported{"bitmask", "bitmask"},
    Unsupported{"map", "map<K, V>"},
    Unsupported{"any", "any"},
    Unsupported{"fixed", "fixed<digits, scale>"},
    Unsupported{"interface", "interface"},
    Unsupported{"valuetype", "valuetype"},
    Unsupported{"exception", "exception"},
    Unsupported{"native", "native"},
    Unsupported{"Object", "Object"},
};
constexpr std::string_view kSubset =
    "the rejuv_msgs generator reads fixed-size structs only (docs/across_hosts.md \"ROS 2 names\")";

// IDL 4's explicit-width names and the classic spellings that are one word.
struct NamedPrimitive {
  std::string_view name;
  Primitive primitive;
};
constexpr std::array kPrimitives{
    NamedPrimitive{"boolean", Primitive::Bool},   NamedPrimitive{"char", Primitive::Char},
    NamedPrimitive{"octet", Primitive::Uint8},    NamedPrimitive{"int8", Primitive::Int8},
    NamedPrimitive{"uint8", Primitive::Uint8},    NamedPrimitive{"int16", Primitive::Int16},
    NamedPrimitive{"uint16", Primitive::Uint16},  NamedPrimitive{"int32", Primitive::Int32},
    NamedPrimitive{"uint32", Primitive::Uint32},  NamedPrimitive{"int64", Primitive::Int64},
    NamedPrimitive{"uint64", Primitive::Uint64},  NamedPrimitive{"float", Primitive::Float32},
    NamedPrimitive{"double", Primitive::Float64}, NamedPrimitive{"short", Primitive::Int16},
};

constexpr std::uint64_t kMaxArraySize = 0x7fffffff;

class Parser {
 public:
  Parser(std::vector<Token> tokens, std::vector<Comment> comments, std::string file, Definitions& defs,
         const IncludeFn& include)
      : tokens_(std::move(tokens)), comments_(std::move(comments)), file_(std::move(file)), defs_(defs),
        include_(include) {}

  Result<void, IdlError> run() {
    if (auto ok = definitions(); !ok) return ok;
    if (peek().kind != Token::Kind::End) return error_at(peek().at, "unexpected '" + peek().text + "': no module is open");
    return {};
  }

 private:
  const Token& peek(std::size_t ahead = 0) const { return tokens_[std::min(i_ + ahead, tokens_.size() - 1)]; }
  const Token& next() { return tokens_[std::min(i_++, tokens_.size() - 1)]; }
  bool at_punct(std::string_view p) const { return peek().kind == Token::Kind::Punct && peek().text == p; }
  bool at_ident(std::string_view w) const { return peek().kind == Token::Kind::Ident && peek().text == w; }

  Result<void, IdlError> expect(std::string_view p, std::string_view where) {
    if (!at_punct(p)) return error_at(peek().at, "expected '" + std::string(p) + "' " + std::string(where) + ", found '" + peek().text + "'");
    ++i_;
    return {};
  }
  Result<std::string, IdlError> identifier(std::string_view what) {
    if (peek().kind != Token::Kind::Ident) return error_at(peek().at, "expected " + std::string(what) + ", found '" + peek().text + "'");
    return next().text;
  }

  std::string scoped(std::string_view name) const {
    std::string s;
    for (const std::string& m : scope_) s += m + "::";
    return s + std::string(name);
  }

  Result<void, IdlError> refuse_unsupported(const Token& t) const {
    for (const Unsupported& u : kUnsupported) {
      if (t.kind == Token::Kind::Ident && t.text == u.keyword) {
        return error_at(t.at, std::string(u.what) + " is not supported: " + std::string(kSubset));
      }
    }
    return {};
  }

  // Definitions until '}' or the end.
  Result<void, IdlError> definitions() {
    while (peek().kind != Token::Kind::End && !at_punct("}")) {
      if (auto ok = definition(); !ok) return ok;
    }
    return {};
  }

  Result<void, IdlError> definition() {
    const Token& t = peek();
    if (t.kind == Token::Kind::Directive) return directive();
    if (at_punct(";")) {
      ++i_;
      return {};
    }
    if (at_ident("module")) return module();
    if (at_ident("enum")) return enumeration();
    if (at_ident("struct") || at_punct("@")) return structure();
    if (auto ok = refuse_unsupported(t); !ok) return ok;
    return error_at(t.at, "expected module, struct or enum, found '" + t.text + "'");
  }

  Result<void, IdlError> directive() {
    const Token t = next();
    std::istringstream words(t.text.substr(1));
    std::string word;
    words >> word;
    if (word != "include") {
      return error_at(t.at, "preprocessor directive '" + t.text + "' is not supported (only #include \"file.idl\")");
    }
    const std::size_t open = t.text.find('"');
    const std::size_t close = t.text.rfind('"');
    if (open == std::string::npos || close <= open) {
      return error_at(t.at, "expected #include \"file.idl\", found '" + t.text + "'");
    }
    if (!include_) return error_at(t.at, "#include is not followed here: read the files with load_idl");
    return include_(std::string_view(t.text).substr(open + 1, close - open - 1), t.at);
  }

  Result<void, IdlError> module() {
    ++i_;
    auto name = identifier("a module name");
    if (!name) return fail(name.error());
    if (auto ok = expect("{", "after the module name"); !ok) return ok;
    scope_.push_back(*name);
    if (auto ok = definitions(); !ok) return ok;
    scope_.pop_back();
    if (auto ok = expect("}", "closing module " + *name); !ok) return ok;
    return expect(";", "after the module's '}'");
  }

  Result<void, IdlError> enumeration() {
    const SourcePos at = next().at;
    auto name = identifier("an enum name");
    if (!name) return fail(name.error());
    if (auto ok = declare(*name, at); !ok) return ok;
    if (auto ok = expect("{", "after the enum name"); !ok) return ok;
    Enum e{.scoped_name = scoped(*name), .name = *name, .enumerators = {}, .at = at};
    while (true) {
      if (at_punct("@")) return error_at(peek().at, "annotations on enumerators (@value) are not supported: values are 0, 1, 2, … in order");
      auto v = identifier("an enumerator");
      if (!v) return fail(v.error());
      e.enumerators.push_back(*v);
      if (at_punct("=")) return error_at(peek().at, "enumerator values are not IDL: values are 0, 1, 2, … in order");
      if (at_punct(",")) {
        ++i_;
        continue;
      }
      break;
    }
    if (auto ok = expect("}", "after the enumerators"); !ok) return ok;
    if (auto ok = expect(";", "after the enum's '}'"); !ok) return ok;
    defs_.enums.push_back(std::move(e));
    return {};
  }

  // A name is declared once in its scope.
  Result<void, IdlError> declare(const std::string& name, const SourcePos& at) {
    const std::string full = scoped(name);
    if (defs_.find_struct(full) != nullptr || defs_.find_enum(full) != nullptr) {
      return error_at(at, "'" + full + "' is declared twice");
    }
    return {};
  }

  // The `//` lines ending on the line above `line`, contiguous.
  std::string comment_above(int line) const {
    std::vector<std::string> lines;
    int want = line - 1;
    for (auto it = comments_.rbegin(); it != comments_.rend(); ++it) {
      if (it->line > want) continue;
      if (it->line < want || it->trailing) break;
      lines.insert(lines.begin(), it->text);
      --want;
    }
    std::string out;
    for (const std::string& l : lines) out += (out.empty() ? "" : "\n") + l;
    return out;
  }

  // The `//` comment after the code on `line`, and the comment-only lines right below it in its column.
  std::string comment_after(int line) const {
    std::string out;
    int column = 0;
    int want = line;
    for (const Comment& c : comments_) {
      if (c.line < want) continue;
      if (c.line > want) break;
      if (want == line ? !c.trailing : (c.trailing || c.column != column)) break;
      column = c.column;
      out += (out.empty() ? "" : " ") + c.text;
      ++want;
    }
    return out;
  }

  Result<void, IdlError> structure() {
    const SourcePos at = peek().at;
    while (at_punct("@")) {
      const SourcePos a = next().at;
      auto name = identifier("an annotation name");
      if (!name) return fail(name.error());
      if (*name != "final") {
        return error_at(a, "annotation @" + *name + " is not supported: only @final structs (their CDR is a ROS 2 message's)");
      }
    }
    if (!at_ident("struct")) {
      if (auto ok = refuse_unsupported(peek()); !ok) return ok;
      return error_at(peek().at, "expected 'struct' after @final, found '" + peek().text + "'");
    }
    ++i_;
    auto name = identifier("a struct name");
    if (!name) return fail(name.error());
    if (at_punct(";")) return error_at(peek().at, "a forward declaration of struct " + *name + " is not supported");
    if (at_punct(":")) return error_at(peek().at, "struct inheritance is not supported: " + std::string(kSubset));
    if (auto ok = declare(*name, at); !ok) return ok;
    if (auto ok = expect("{", "after the struct name"); !ok) return ok;
    const std::string base = file_.substr(file_.find_last_of('/') + 1);
    Struct s{.scoped_name = scoped(*name), .name = *name, .members = {}, .comment = comment_above(at.line),
             .file = base, .at = at};
    std::set<std::string> names;
    while (!at_punct("}")) {
      auto m = member();
      if (!m) return fail(m.error());
      if (!names.insert(m->name).second) return error_at(m->at, "member '" + m->name + "' is declared twice in " + s.scoped_name);
      s.members.push_back(std::move(*m));
    }
    if (s.members.empty()) return error_at(peek().at, "struct " + s.scoped_name + " has no members");
    ++i_;
    if (auto ok = expect(";", "after the struct's '}'"); !ok) return ok;
    defs_.structs.push_back(std::move(s));
    return {};
  }

  Result<MemberType, IdlError> type() {
    const Token& t = peek();
    if (t.kind == Token::Kind::Punct && t.text == "@") {
      return error_at(t.at, "annotations on members (@key, @optional, @id, …) are not supported: " + std::string(kSubset));
    }
    if (auto ok = refuse_unsupported(t); !ok) return fail(ok.error());
    if (t.kind != Token::Kind::Ident && !(t.kind == Token::Kind::Punct && t.text == "::")) {
      return error_at(t.at, "expected a member type, found '" + t.text + "'");
    }
    const auto primitive = [](Primitive p) { return MemberType{.kind = MemberType::Kind::Primitive, .primitive = p}; };
    if (at_ident("unsigned")) {
      ++i_;
      if (at_ident("short")) return ++i_, primitive(Primitive::Uint16);
      if (at_ident("long")) {
        ++i_;
        if (at_ident("long")) return ++i_, primitive(Primitive::Uint64);
        return primitive(Primitive::Uint32);
      }
      return error_at(peek().at, "expected 'short' or 'long' after 'unsigned', found '" + peek().text + "'");
    }
    if (at_ident("long")) {
      ++i_;
      if (at_ident("long")) return ++i_, primitive(Primitive::Int64);
      if (at_ident("double")) return error_at(t.at, "long double is not supported: ROS 2 messages have no 128-bit float");
      return primitive(Primitive::Int32);
    }
    for (const NamedPrimitive& p : kPrimitives) {
      if (at_ident(p.name)) return ++i_, primitive(p.primitive);
    }
    return named_type();
  }

  // A struct or enum declared before: `::a::b::T` absolutely, `b::T` or `T` from the innermost scope outward.
  Result<MemberType, IdlError> named_type() {
    const SourcePos at = peek().at;
    bool absolute = false;
    if (at_punct("::")) {
      absolute = true;
      ++i_;
    }
    std::string name;
    while (true) {
      auto part = identifier("a type name");
      if (!part) return fail(part.error());
      name += *part;
      if (!at_punct("::")) break;
      ++i_;
      name += "::";
    }
    std::vector<std::string> candidates;
    if (absolute) {
      candidates.push_back(name);
    } else {
      for (std::size_t depth = scope_.size() + 1; depth-- > 0;) {
        std::string prefix;
        for (std::size_t k = 0; k < depth; ++k) prefix += scope_[k] + "::";
        candidates.push_back(prefix + name);
      }
    }
    for (const std::string& c : candidates) {
      if (defs_.find_struct(c) != nullptr) return MemberType{.kind = MemberType::Kind::Struct, .scoped_name = c};
      if (defs_.find_enum(c) != nullptr) return MemberType{.kind = MemberType::Kind::Enum, .scoped_name = c};
    }
    return error_at(at, "unknown type '" + std::string(absolute ? "::" : "") + name +
                            "': no struct or enum of that name is declared before it (an IDL type is declared before "
                            "its use; another file's types come with #include)");
  }

  Result<Member, IdlError> member() {
    const SourcePos at = peek().at;
    auto t = type();
    if (!t) return fail(t.error());
    if (at_punct("<")) return error_at(peek().at, "template types are not supported: " + std::string(kSubset));
    auto name = identifier("a member name");
    if (!name) return fail(name.error());
    Member m{.name = *name, .type = *t, .array_size = std::nullopt, .comment = {}, .at = at};
    if (at_punct("[")) {
      ++i_;
      const Token& n = peek();
      std::uint64_t size = 0;
      bool digits = n.kind == Token::Kind::Number && !n.text.empty() && n.text.size() <= 10;
      for (const char c : n.text) digits = digits && std::isdigit(static_cast<unsigned char>(c)) != 0;
      if (digits) size = std::stoull(n.text);
      if (!digits || size == 0 || size > kMaxArraySize || (n.text.size() > 1 && n.text[0] == '0')) {
        return error_at(n.at, "an array size is a decimal integer 1.." + std::to_string(kMaxArraySize) + ", found '" + n.text + "'");
      }
      ++i_;
      if (auto ok = expect("]", "after the array size"); !ok) return fail(ok.error());
      if (at_punct("[")) return error_at(peek().at, "multi-dimensional arrays are not supported: ROS 2 messages have one dimension");
      m.array_size = static_cast<std::uint32_t>(size);
    }
    if (at_punct(",")) return error_at(peek().at, "one member per declaration: declare '" + m.name + "' and the next on lines of their own");
    const Token& semi = peek();
    if (auto ok = expect(";", "after member " + m.name); !ok) return fail(ok.error());
    m.comment = comment_after(semi.at.line);
    return m;
  }

  std::vector<Token> tokens_;
  std::vector<Comment> comments_;
  std::string file_;
  Definitions& defs_;
  const IncludeFn& include_;
  std::size_t i_ = 0;
  std::vector<std::string> scope_;
};

Result<std::string, IdlError> read_file(const std::filesystem::path& path, const SourcePos& from) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return error_at(from, "cannot read " + path.string());
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

Result<void, IdlError> parse_idl(std::string_view text, const std::string& file, Definitions& defs,
                                 const IncludeFn& include) {
  auto lexed = lex(text, file);
  if (!lexed) return fail(lexed.error());
  Parser p(std::move(lexed->tokens), std::move(lexed->comments), file, defs, include);
  return p.run();
}

Result<Definitions, IdlError> load_idl(std::span<const std::filesystem::path> files) {
  Definitions defs;
  std::set<std::filesystem::path> read;
  // Reads `path` unless read already; `from` is where it was named (the #include, or the command line).
  std::function<Result<void, IdlError>(const std::filesystem::path&, const SourcePos&)> load =
      [&](const std::filesystem::path& path, const SourcePos& from) -> Result<void, IdlError> {
    std::error_code ec;
    const std::filesystem::path canonical = std::filesystem::weakly_canonical(path, ec);
    if (!read.insert(ec ? path : canonical).second) return {};
    auto text = read_file(path, from);
    if (!text) return fail(text.error());
    const IncludeFn include = [&](std::string_view name, const SourcePos& at) {
      return load(path.parent_path() / name, at);
    };
    return parse_idl(*text, path.string(), defs, include);
  };
  for (const std::filesystem::path& f : files) {
    if (auto ok = load(f, SourcePos{.file = f.string(), .line = 0, .column = 0}); !ok) return fail(ok.error());
  }
  return defs;
}

}  // namespace rejuv::ros2_msgs
