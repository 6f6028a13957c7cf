// Strict command-line parsing for `rejuv` subcommands: every bad flag gets a precise error, never a crash.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"

namespace rejuv::cli {

// Process exit codes shared by every subcommand.
enum class Exit : int {
  Ok = 0,
  Findings = 1,    // the command ran and found a problem (audit violation, mission failed, test failed)
  BadInput = 2,    // bad flag, unreadable or malformed file
};

enum class ParseOutcome : std::uint8_t { Run, HelpShown };

class ArgParser {
 public:
  ArgParser(std::string command, std::string summary);

  // --name (no value).
  ArgParser& flag(std::string name, bool& out, std::string help);
  // --name VALUE or --name=VALUE; `set` is true once given.
  ArgParser& option(std::string name, std::string metavar, std::string& out, std::string help,
                    bool* set = nullptr);
  // --name VALUE that may be given several times (each value appended).
  ArgParser& repeated(std::string name, std::string metavar, std::vector<std::string>& out, std::string help);
  // A positional argument; required ones must be present.
  ArgParser& positional(std::string name, std::string& out, std::string help, bool required = true);
  // Every positional argument after the named ones (at least one), e.g. `merge DIR...`.
  ArgParser& positionals(std::string name, std::vector<std::string>& out, std::string help);

  // Parses args (without the program and command names). On error: the message to print.
  [[nodiscard]] Result<ParseOutcome, std::string> parse(std::span<const std::string_view> args);
  [[nodiscard]] std::string help() const;

 private:
  struct Opt {
    std::string name, metavar, help;
    bool* flag_out = nullptr;
    std::string* value_out = nullptr;
    bool* set_out = nullptr;
    std::vector<std::string>* list_out = nullptr;
  };
  struct Pos {
    std::string name, help;
    std::string* out;
    bool required;
  };
  std::string command_, summary_;
  std::vector<Opt> opts_;
  std::vector<Pos> pos_;
  std::vector<std::string>* rest_ = nullptr;
  std::string rest_name_, rest_help_;
};

// Typed conversions of option values, with the option named in the error.
[[nodiscard]] Result<std::uint64_t, std::string> to_u64(std::string_view text, std::string_view option);
[[nodiscard]] Result<double, std::string> to_double(std::string_view text, std::string_view option);
// One of `choices`, e.g. --format text|json.
[[nodiscard]] Result<std::string, std::string> to_choice(std::string_view text, std::string_view option,
                                                         std::initializer_list<std::string_view> choices);

}  // namespace rejuv::cli
