#include "args.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

namespace rejuv::cli {

ArgParser::ArgParser(std::string command, std::string summary)
    : command_(std::move(command)), summary_(std::move(summary)) {}

ArgParser& ArgParser::flag(std::string name, bool& out, std::string help) {
  opts_.push_back(Opt{.name = std::move(name), .metavar = "", .help = std::move(help), .flag_out = &out});
  return *this;
}

ArgParser& ArgParser::option(std::string name, std::string metavar, std::string& out, std::string help,
                             bool* set) {
  opts_.push_back(Opt{.name = std::move(name),
                      .metavar = std::move(metavar),
                      .help = std::move(help),
                      .value_out = &out,
                      .set_out = set});
  return *this;
}

ArgParser& ArgParser::repeated(std::string name, std::string metavar, std::vector<std::string>& out,
                               std::string help) {
  opts_.push_back(Opt{.name = std::move(name), .metavar = std::move(metavar), .help = std::move(help), .list_out = &out});
  return *this;
}

ArgParser& ArgParser::positionals(std::string name, std::vector<std::string>& out, std::string help) {
  rest_ = &out;
  rest_name_ = std::move(name);
  rest_help_ = std::move(help);
  return *this;
}

ArgParser& ArgParser::positional(std::string name, std::string& out, std::string help, bool required) {
  pos_.push_back(Pos{std::move(name), std::move(help), &out, required});
  return *this;
}

std::string ArgParser::help() const {
  std::ostringstream s;
  s << "usage: rejuv " << command_;
  for (const Opt& o : opts_) {
    s << " [" << o.name << (o.metavar.empty() ? "" : " " + o.metavar) << "]";
  }
  for (const Pos& p : pos_) {
    s << (p.required ? " " : " [") << p.name << (p.required ? "" : "]");
  }
  if (rest_ != nullptr) s << " " << rest_name_ << "...";
  s << "\n\n" << summary_ << "\n";
  if (!pos_.empty() || rest_ != nullptr) {
    s << "\narguments:\n";
    for (const Pos& p : pos_) s << "  " << p.name << std::string(p.name.size() < 22 ? 22 - p.name.size() : 1, ' ') << p.help << "\n";
    if (rest_ != nullptr) {
      s << "  " << rest_name_ << "..." << std::string(rest_name_.size() < 19 ? 19 - rest_name_.size() : 1, ' ')
        << rest_help_ << "\n";
    }
  }
  s << "\noptions:\n";
  for (const Opt& o : opts_) {
    const std::string left = o.name + (o.metavar.empty() ? "" : " " + o.metavar);
    s << "  " << left << std::string(left.size() < 22 ? 22 - left.size() : 1, ' ') << o.help << "\n";
  }
  s << "  --help                show this help\n";
  return s.str();
}

Result<ParseOutcome, std::string> ArgParser::parse(std::span<const std::string_view> args) {
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
      const Opt* found = nullptr;
      for (const Opt& o : opts_) {
        if (o.name == name) found = &o;
      }
      if (found == nullptr) {
        return fail("unknown option '" + std::string(name) + "' for 'rejuv " + command_ + "'" + see);
      }
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
      } else {
        return fail("option '" + std::string(name) + "' needs a value " + found->metavar + see);
      }
      if (value.empty()) {
        return fail("option '" + std::string(name) + "' needs a non-empty value " + found->metavar + see);
      }
      if (found->list_out != nullptr) {
        found->list_out->emplace_back(value);
        continue;
      }
      *found->value_out = std::string(value);
      if (found->set_out != nullptr) *found->set_out = true;
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
  if (rest_ != nullptr && rest_->empty()) return fail("missing argument " + rest_name_ + see);
  return ParseOutcome::Run;
}

Result<std::uint64_t, std::string> to_u64(std::string_view text, std::string_view option) {
  std::uint64_t v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || ptr != text.data() + text.size()) {
    return fail("option '" + std::string(option) + "' expects a non-negative integer, got '" +
                std::string(text) + "'");
  }
  return v;
}

Result<double, std::string> to_double(std::string_view text, std::string_view option) {
  double v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || ptr != text.data() + text.size() || !std::isfinite(v)) {
    return fail("option '" + std::string(option) + "' expects a finite number, got '" + std::string(text) + "'");
  }
  return v;
}

Result<std::string, std::string> to_choice(std::string_view text, std::string_view option,
                                           std::initializer_list<std::string_view> choices) {
  std::string list;
  for (const std::string_view c : choices) {
    if (c == text) return std::string(text);
    list += (list.empty() ? "" : "|") + std::string(c);
  }
  return fail("option '" + std::string(option) + "' expects one of " + list + ", got '" + std::string(text) + "'");
}

}  // namespace rejuv::cli
