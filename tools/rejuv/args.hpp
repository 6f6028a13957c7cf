// The typed option layer of every `rejuv` subcommand. A command declares its options once,
// as a table: name, metavar, value type (flag, integer or real with a range, text, path, one of a list of
// choices, or a value of the command's own syntax), the default (the variable's value when it is declared, or
// what an unset optional means) and a help line. From that one table `Options` parses the arguments, checks
// every value (range, choice, syntax) with one error format, and writes the command's --help, so the help
// and the parser cannot disagree: the help's "(1..16; default 1)" is printed from the same bounds and
// default the parser applies. Relations between options (--trace needs --out) stay in the command.
//
// Errors, on stderr as "rejuv CMD: …" with exit 2 (README "Exit codes"):
//   unknown option '--x' for 'rejuv CMD' (see 'rejuv CMD --help')
//   option '--jobs' needs a value J
//   --jobs: expected an integer in 1..16, got '0'
//   --trace: expected compact or full, got 'some'
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rejuv/core/result.hpp"

namespace rejuv::cli {

// Process exit codes shared by every subcommand.
enum class Exit : int {
  Ok = 0,
  Findings = 1,    // the command ran and found a problem (audit violation, mission failed, test failed)
  BadInput = 2,    // bad flag, unreadable or malformed file
};

// Text as it is (no printf formatting) on `to`.
void print(std::FILE* to, std::string_view text);
// A refusal of bad input (README "Exit codes"), the one every command gives: `message` and a newline on stderr;
// returns Exit::BadInput (2).
[[nodiscard]] int refuse(std::string_view message);
// The same as "rejuv COMMAND: message", the form of Options' own errors (parse_or_exit).
[[nodiscard]] int refuse(std::string_view command, std::string_view message);

enum class ParseOutcome : std::uint8_t { Run, HelpShown };

// The inclusive bounds of an integer option.
struct IntRange {
  std::uint64_t min = 0;
  std::uint64_t max = std::numeric_limits<std::uint64_t>::max();
};

// The bounds of a real option (always finite); an open end excludes its bound, e.g. (0, 1e6).
struct RealRange {
  double min = -std::numeric_limits<double>::max();
  double max = std::numeric_limits<double>::max();
  bool open_min = false;
  bool open_max = false;
};

// One choice of an enumerated option: the word on the command line and its value.
template <class E>
struct Choice {
  std::string_view word;
  E value;
};

class Options {
 public:
  Options(std::string command, std::string summary);

  // --name, no value.
  Options& flag(std::string name, bool& out, std::string help);
  // --name N: an integer in `range`. `out` holds the default (shown in the help) or, optional, stays unset;
  // `unset` says in the help what an absent option means ("the graph's").
  Options& integer(std::string name, std::string metavar, std::uint64_t& out, IntRange range, std::string help);
  Options& integer(std::string name, std::string metavar, std::optional<std::uint64_t>& out, IntRange range,
                   std::string help, std::string unset = "");
  // --name X: a finite real number in `range`.
  Options& real(std::string name, std::string metavar, double& out, RealRange range, std::string help);
  Options& real(std::string name, std::string metavar, std::optional<double>& out, RealRange range, std::string help,
                std::string unset = "");
  // --name TEXT: any non-empty text.
  Options& text(std::string name, std::string metavar, std::string& out, std::string help);
  Options& text(std::string name, std::string metavar, std::optional<std::string>& out, std::string help,
                std::string unset = "");
  // --name FILE or DIR: a path (what it must be, the command checks when it opens it).
  Options& path(std::string name, std::string metavar, std::filesystem::path& out, std::string help);
  Options& path(std::string name, std::string metavar, std::optional<std::filesystem::path>& out, std::string help,
                std::string unset = "");
  // --name a|b|c: one of `choices` (the metavar is made of them).
  template <class E>
  Options& choice(std::string name, std::vector<Choice<E>> choices, E& out, std::string help);
  template <class E>
  Options& choice(std::string name, std::vector<Choice<E>> choices, std::optional<E>& out, std::string help,
                  std::string unset = "");
  // --name VALUE of the command's own syntax (waypoints, a shard i/n, a CPU or 'all'): `convert` turns the
  // text into the value or returns the error, which names the option.
  template <class T>
  Options& custom(std::string name, std::string metavar, std::optional<T>& out,
                  std::function<Result<T, std::string>(std::string_view)> convert, std::string help,
                  std::string unset = "");
  // --name VALUE that may be given several times (each value appended).
  Options& repeated(std::string name, std::string metavar, std::vector<std::string>& out, std::string help);
  // The option declared last must be given (the usage line shows it without brackets; parse refuses its absence).
  Options& required();
  // A positional argument; required ones must be present.
  Options& positional(std::string name, std::string& out, std::string help, bool required = true);
  // Every positional argument after the named ones (at least one unless not `required`), e.g. `merge DIR...`.
  Options& positionals(std::string name, std::vector<std::string>& out, std::string help, bool required = true);

  // Parses args (without the program and command names); nothing is printed. On error: the message.
  [[nodiscard]] Result<ParseOutcome, std::string> parse(std::span<const std::string_view> args);
  // Parses as a command does: nullopt to go on; otherwise the help was printed on stdout (exit 0) or
  // "rejuv CMD: <error>" on stderr (exit 2), and the exit code to return.
  [[nodiscard]] std::optional<int> parse_or_exit(std::span<const std::string_view> args);
  // Whether the option was given on the command line (for relations between options).
  [[nodiscard]] bool given(std::string_view name) const;
  [[nodiscard]] std::string help() const;
  [[nodiscard]] const std::string& command() const { return command_; }

 private:
  // Whether a value's error message names its option already (custom syntaxes) or gets "--name: " before it.
  enum class ErrorNames : std::uint8_t { Option, Itself };
  using Setter = std::function<Result<void, std::string>(std::string_view)>;
  struct Opt {
    std::string name{}, metavar{}, help{};
    std::string bounds{};    // "1..16", "K >= 0": what the help says a value must be ("" = anything)
    std::string fallback{};  // "default 1", "default: the graph's" ("" = none)
    bool* flag_out = nullptr;
    Setter set{};
    ErrorNames names = ErrorNames::Option;
    bool given = false;
    bool repeatable = false;  // repeated(): each value appended; any other option may be given once
    bool required = false;    // required(): parse refuses its absence
  };
  struct Pos {
    std::string name, help;
    std::string* out;
    bool required;
  };
  Options& add_value(std::string name, std::string metavar, std::string help, std::string bounds,
                     std::string fallback, Setter set, ErrorNames names = ErrorNames::Option);
  static std::string choice_words(const std::vector<std::string_view>& words, std::string_view sep,
                                  std::string_view last_sep);
  // What an unset option means, for the help: "default: the graph's" ("" when nothing is said).
  static std::string unset_note(const std::string& unset);
  // A setter that converts the text and stores the value in `out` (a T or an optional<T>).
  template <class T, class Out>
  static Setter assign(std::function<Result<T, std::string>(std::string_view)> convert, Out& out);
  // The conversion of a word to its choice; `meta` gets "a|b|c".
  template <class E>
  static std::function<Result<E, std::string>(std::string_view)> chooser(const std::vector<Choice<E>>& choices,
                                                                         std::string& meta);

  std::string command_, summary_;
  std::vector<Opt> opts_;
  std::vector<Pos> pos_;
  std::vector<std::string>* rest_ = nullptr;
  std::string rest_name_, rest_help_;
  bool rest_required_ = true;
};

// Typed conversions of a value, with the option named in the error (also for values inside a custom syntax).
[[nodiscard]] Result<std::uint64_t, std::string> to_u64(std::string_view text, std::string_view option);
[[nodiscard]] Result<double, std::string> to_double(std::string_view text, std::string_view option);

// ---- templates ----

template <class T, class Out>
Options::Setter Options::assign(std::function<Result<T, std::string>(std::string_view)> convert, Out& out) {
  return [convert = std::move(convert), &out](std::string_view text) -> Result<void, std::string> {
    auto v = convert(text);
    if (!v) return fail(std::move(v.error()));
    out = std::move(*v);
    return {};
  };
}

template <class E>
std::function<Result<E, std::string>(std::string_view)> Options::chooser(const std::vector<Choice<E>>& choices,
                                                                         std::string& meta) {
  std::vector<std::string_view> words;
  for (const Choice<E>& c : choices) words.push_back(c.word);
  meta = choice_words(words, "|", "|");
  return [choices, expected = choice_words(words, ", ", " or ")](std::string_view text) -> Result<E, std::string> {
    for (const Choice<E>& c : choices) {
      if (c.word == text) return c.value;
    }
    return fail("expected " + expected + ", got '" + std::string(text) + "'");
  };
}

template <class E>
Options& Options::choice(std::string name, std::vector<Choice<E>> choices, E& out, std::string help) {
  std::string meta, fallback;
  for (const Choice<E>& c : choices) {
    if (c.value == out) fallback = "default " + std::string(c.word);
  }
  auto convert = chooser(choices, meta);
  return add_value(std::move(name), std::move(meta), std::move(help), "", std::move(fallback),
                   assign<E>(std::move(convert), out));
}

template <class E>
Options& Options::choice(std::string name, std::vector<Choice<E>> choices, std::optional<E>& out, std::string help,
                         std::string unset) {
  std::string meta;
  auto convert = chooser(choices, meta);
  return add_value(std::move(name), std::move(meta), std::move(help), "", unset_note(unset),
                   assign<E>(std::move(convert), out));
}

template <class T>
Options& Options::custom(std::string name, std::string metavar, std::optional<T>& out,
                         std::function<Result<T, std::string>(std::string_view)> convert, std::string help,
                         std::string unset) {
  return add_value(std::move(name), std::move(metavar), std::move(help), "", unset_note(unset),
                   assign<T>(std::move(convert), out), ErrorNames::Itself);
}

}  // namespace rejuv::cli
