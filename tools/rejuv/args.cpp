// The typed option layer (args.hpp): declaration, parsing and the generated --help.
#include "args.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace rejuv::cli {

namespace {

// "0.1" rather than "0.100000": bounds and defaults are printed the way users write them.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string int_bounds(IntRange r) {
  if (r.max == std::numeric_limits<std::uint64_t>::max()) {
    return r.min == 0 ? "" : "at least " + std::to_string(r.min);
  }
  return std::to_string(r.min) + ".." + std::to_string(r.max);
}

std::string real_bounds(RealRange r) {
  const bool low = r.min > -std::numeric_limits<double>::max();
  const bool high = r.max < std::numeric_limits<double>::max();
  if (low && high) {
    return (r.open_min ? "(" : "[") + num(r.min) + ", " + num(r.max) + (r.open_max ? ")" : "]");
  }
  if (low) return (r.open_min ? "> " : ">= ") + num(r.min);
  if (high) return (r.open_max ? "< " : "<= ") + num(r.max);
  return "";
}

// The bounds in the help, with the option's metavar: "0 < S < 1e+06", "K >= 0".
std::string real_note(RealRange r, const std::string& metavar) {
  const bool low = r.min > -std::numeric_limits<double>::max();
  const bool high = r.max < std::numeric_limits<double>::max();
  std::string out;
  if (low) out += num(r.min) + (r.open_min ? " < " : " <= ");
  if (low || high) out += metavar;
  if (high) out += (r.open_max ? " < " : " <= ") + num(r.max);
  if (low && !high) out = metavar + (r.open_min ? " > " : " >= ") + num(r.min);
  return out;
}

Result<std::uint64_t, std::string> integer_in(std::string_view text, IntRange r) {
  std::uint64_t v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || ptr != text.data() + text.size() || v < r.min || v > r.max) {
    const std::string b = int_bounds(r);
    return fail("expected " + (b.empty() ? std::string("a non-negative integer") : "an integer " +
                                   (b.starts_with("at least") ? b : "in " + b)) +
                ", got '" + std::string(text) + "'");
  }
  return v;
}

Result<double, std::string> real_in(std::string_view text, RealRange r) {
  double v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  const bool number = ec == std::errc{} && ptr == text.data() + text.size() && std::isfinite(v);
  const bool in = number && (r.open_min ? v > r.min : v >= r.min) && (r.open_max ? v < r.max : v <= r.max);
  if (!in) {
    const std::string b = real_bounds(r);
    return fail("expected " + (b.empty() ? std::string("a finite number") : "a number " + (b[0] == '(' || b[0] == '[' ? "in " + b : b)) +
                ", got '" + std::string(text) + "'");
  }
  return v;
}

// The conversions of the value types, as the setters take them.
std::function<Result<std::uint64_t, std::string>(std::string_view)> integers_in(IntRange r) {
  return [r](std::string_view text) { return integer_in(text, r); };
}
std::function<Result<double, std::string>(std::string_view)> reals_in(RealRange r) {
  return [r](std::string_view text) { return real_in(text, r); };
}
Result<std::string, std::string> as_text(std::string_view text) { return std::string(text); }
Result<std::filesystem::path, std::string> as_path(std::string_view text) { return std::filesystem::path(text); }

}  // namespace

Options::Options(std::string command, std::string summary)
    : command_(std::move(command)), summary_(std::move(summary)) {}

std::string Options::choice_words(const std::vector<std::string_view>& words, std::string_view sep,
                                  std::string_view last_sep) {
  std::string out;
  for (std::size_t i = 0; i < words.size(); ++i) {
    if (i > 0) out += i + 1 == words.size() ? last_sep : sep;
    out += words[i];
  }
  return out;
}

Options& Options::add_value(std::string name, std::string metavar, std::string help, std::string bounds,
                            std::string fallback, Setter set, ErrorNames names) {
  opts_.push_back(Opt{.name = std::move(name),
                      .metavar = std::move(metavar),
                      .help = std::move(help),
                      .bounds = std::move(bounds),
                      .fallback = std::move(fallback),
                      .set = std::move(set),
                      .names = names});
  return *this;
}

Options& Options::flag(std::string name, bool& out, std::string help) {
  opts_.push_back(Opt{.name = std::move(name), .metavar = "", .help = std::move(help), .flag_out = &out});
  return *this;
}

std::string Options::unset_note(const std::string& unset) { return unset.empty() ? "" : "default: " + unset; }

Options& Options::integer(std::string name, std::string metavar, std::uint64_t& out, IntRange range,
                          std::string help) {
  return add_value(std::move(name), std::move(metavar), std::move(help), int_bounds(range),
                   "default " + std::to_string(out), assign<std::uint64_t>(integers_in(range), out));
}

Options& Options::integer(std::string name, std::string metavar, std::optional<std::uint64_t>& out, IntRange range,
                          std::string help, std::string unset) {
  return add_value(std::move(name), std::move(metavar), std::move(help), int_bounds(range), unset_note(unset),
                   assign<std::uint64_t>(integers_in(range), out));
}

Options& Options::real(std::string name, std::string metavar, double& out, RealRange range, std::string help) {
  std::string note = real_note(range, metavar);
  return add_value(std::move(name), std::move(metavar), std::move(help), std::move(note), "default " + num(out),
                   assign<double>(reals_in(range), out));
}

Options& Options::real(std::string name, std::string metavar, std::optional<double>& out, RealRange range,
                       std::string help, std::string unset) {
  std::string note = real_note(range, metavar);
  return add_value(std::move(name), std::move(metavar), std::move(help), std::move(note), unset_note(unset),
                   assign<double>(reals_in(range), out));
}

Options& Options::text(std::string name, std::string metavar, std::string& out, std::string help) {
  std::string fallback = out.empty() ? "" : "default " + out;
  return add_value(std::move(name), std::move(metavar), std::move(help), "", std::move(fallback),
                   assign<std::string>(as_text, out));
}

Options& Options::text(std::string name, std::string metavar, std::optional<std::string>& out, std::string help,
                       std::string unset) {
  return add_value(std::move(name), std::move(metavar), std::move(help), "", unset_note(unset),
                   assign<std::string>(as_text, out));
}

Options& Options::path(std::string name, std::string metavar, std::filesystem::path& out, std::string help) {
  std::string fallback = out.empty() ? "" : "default " + out.string();
  return add_value(std::move(name), std::move(metavar), std::move(help), "", std::move(fallback),
                   assign<std::filesystem::path>(as_path, out));
}

Options& Options::path(std::string name, std::string metavar, std::optional<std::filesystem::path>& out,
                       std::string help, std::string unset) {
  return add_value(std::move(name), std::move(metavar), std::move(help), "", unset_note(unset),
                   assign<std::filesystem::path>(as_path, out));
}

Options& Options::repeated(std::string name, std::string metavar, std::vector<std::string>& out, std::string help) {
  add_value(std::move(name), std::move(metavar), std::move(help), "", "",
            [&out](std::string_view text) -> Result<void, std::string> {
              out.emplace_back(text);
              return {};
            });
  opts_.back().repeatable = true;
  return *this;
}

Options& Options::required() {
  if (!opts_.empty()) opts_.back().required = true;
  return *this;
}

Options& Options::positionals(std::string name, std::vector<std::string>& out, std::string help, bool required) {
  rest_ = &out;
  rest_name_ = std::move(name);
  rest_help_ = std::move(help);
  rest_required_ = required;
  return *this;
}

Options& Options::positional(std::string name, std::string& out, std::string help, bool required) {
  pos_.push_back(Pos{std::move(name), std::move(help), &out, required});
  return *this;
}

namespace {

// "  LEFT  help", the help's continuation lines under its first.
void help_row(std::ostringstream& s, const std::string& left, const std::string& help) {
  constexpr std::size_t kColumn = 24;
  s << "  " << left << std::string(left.size() + 2 < kColumn ? kColumn - 2 - left.size() : 1, ' ');
  std::size_t at = 0;
  while (true) {
    const std::size_t nl = help.find('\n', at);
    s << help.substr(at, nl == std::string::npos ? std::string::npos : nl - at) << "\n";
    if (nl == std::string::npos) break;
    at = nl + 1;
    s << std::string(kColumn, ' ');
  }
}

}  // namespace

std::string Options::help() const {
  std::ostringstream s;
  s << "usage: rejuv " << command_;
  for (const Opt& o : opts_) {
    const std::string word = o.name + (o.metavar.empty() ? "" : " " + o.metavar) + (o.repeatable ? " ..." : "");
    s << (o.required ? " " + word : " [" + word + "]");
  }
  for (const Pos& p : pos_) {
    s << (p.required ? " " : " [") << p.name << (p.required ? "" : "]");
  }
  if (rest_ != nullptr) s << (rest_required_ ? " " : " [") << rest_name_ << "..." << (rest_required_ ? "" : "]");
  s << "\n\n" << summary_ << "\n";
  if (!pos_.empty() || rest_ != nullptr) {
    s << "\narguments:\n";
    for (const Pos& p : pos_) help_row(s, p.name, p.help);
    if (rest_ != nullptr) help_row(s, rest_name_ + "...", rest_help_);
  }
  s << "\noptions:\n";
  for (const Opt& o : opts_) {
    std::string line = o.help;
    std::string note = o.bounds;
    if (!o.fallback.empty()) note += (note.empty() ? "" : "; ") + o.fallback;
    if (!note.empty()) line += " (" + note + ")";
    help_row(s, o.name + (o.metavar.empty() ? "" : " " + o.metavar), line);
  }
  help_row(s, "--help", "show this help");
  return s.str();
}

bool Options::given(std::string_view name) const {
  for (const Opt& o : opts_) {
    if (o.name == name) return o.given;
  }
  return false;
}

Result<ParseOutcome, std::string> Options::parse(std::span<const std::string_view> args) {
  std::size_t next_pos = 0;
  const std::string see = " (see 'rejuv " + command_ + " --help')";
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string_view a = args[i];
    if (a == "--help" || a == "-h") {
      return ParseOutcome::HelpShown;
    }
    if (a.starts_with("-") && a.size() > 1) {
      const std::size_t eq = a.find('=');
      const std::string_view name = a.substr(0, eq);
      Opt* found = nullptr;
      for (Opt& o : opts_) {
        if (o.name == name) found = &o;
      }
      if (found == nullptr) {
        return fail("unknown option '" + std::string(name) + "' for 'rejuv " + command_ + "'" + see);
      }
      // Given twice, one would silently replace the other (`--seed 1 --seed 2` flew seed 2; two --attack flew
      // the last): refused, unless the option collects its values (repeated()).
      if (found->given && !found->repeatable) {
        return fail("option '" + std::string(name) + "' given twice (it takes one value; give it once)" + see);
      }
      found->given = true;
      if (found->flag_out != nullptr) {
        if (eq != std::string_view::npos) {
          return fail("option '" + std::string(name) + "' takes no value" + see);
        }
        *found->flag_out = true;
        continue;
      }
      std::string_view value;
      if (eq != std::string_view::npos) {
        value = a.substr(eq + 1);
      } else if (i + 1 < args.size()) {
        value = args[++i];
        // The next word is another option of this command: the value was forgotten (`--ulog --no-figures`
        // once wrote a 65 MB log named '--no-figures'). A value that really begins so is given with '='.
        if (value.starts_with("--")) {
          const std::string_view other = value.substr(0, value.find('='));
          const bool known = std::ranges::any_of(opts_, [&](const Opt& o) { return o.name == other; }) ||
                             other == "--help";
          if (known) {
            return fail("option '" + std::string(name) + "' needs a value " + found->metavar + ", got the option '" +
                        std::string(other) + "' (a value that begins with '--' is written " + std::string(name) +
                        "=VALUE)" + see);
          }
        }
      } else {
        return fail("option '" + std::string(name) + "' needs a value " + found->metavar + see);
      }
      if (value.empty()) {
        return fail("option '" + std::string(name) + "' needs a non-empty value " + found->metavar + see);
      }
      if (auto ok = found->set(value); !ok) {
        return fail(found->names == ErrorNames::Itself ? ok.error() : found->name + ": " + ok.error());
      }
      continue;
    }
    if (next_pos >= pos_.size() && rest_ != nullptr) {
      rest_->emplace_back(a);
      continue;
    }
    if (next_pos >= pos_.size()) {
      return fail("unexpected argument '" + std::string(a) + "'" + see);
    }
    *pos_[next_pos++].out = std::string(a);
  }
  for (std::size_t p = next_pos; p < pos_.size(); ++p) {
    if (pos_[p].required) {
      return fail("missing argument " + pos_[p].name + see);
    }
  }
  for (const Opt& o : opts_) {
    if (o.required && !o.given) return fail("missing option " + o.name + " " + o.metavar + see);
  }
  if (rest_ != nullptr && rest_required_ && rest_->empty()) return fail("missing argument " + rest_name_ + see);
  return ParseOutcome::Run;
}

void print(std::FILE* to, std::string_view text) {
  std::fwrite(text.data(), 1, text.size(), to);
}

int refuse(std::string_view message) {
  print(stderr, std::string(message) + "\n");
  return static_cast<int>(Exit::BadInput);
}

int refuse(std::string_view command, std::string_view message) {
  return refuse("rejuv " + std::string(command) + ": " + std::string(message));
}

std::optional<int> Options::parse_or_exit(std::span<const std::string_view> args) {
  const auto parsed = parse(args);
  if (!parsed) {
    return refuse(command_, parsed.error());
  }
  switch (*parsed) {
    case ParseOutcome::HelpShown: std::fputs(help().c_str(), stdout); return static_cast<int>(Exit::Ok);
    case ParseOutcome::Run: break;
  }
  return std::nullopt;
}

Result<std::uint64_t, std::string> to_u64(std::string_view text, std::string_view option) {
  auto v = integer_in(text, {});
  if (!v) return fail(std::string(option) + ": " + v.error());
  return v;
}

Result<double, std::string> to_double(std::string_view text, std::string_view option) {
  auto v = real_in(text, {});
  if (!v) return fail(std::string(option) + ": " + v.error());
  return v;
}

}  // namespace rejuv::cli
