// Every `rejuv` command as a user meets its options (tools/rejuv/args.hpp, README "Exit codes"): --help exits 0
// and shows the ranges and defaults the parser applies; a wrong flag, a value out of range and a missing value
// exit 2 with an error naming the option, before any work.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "../../rejuv_cli.hpp"

namespace {

using rejuv::test_support::kRepo;

class CliCommands : public rejuv::test_support::ScratchDirTest {
 protected:
  CliCommands() : ScratchDirTest("rejuv_cli_commands_test_") {}
  rejuv::test_support::CliOutcome rejuv(const std::vector<std::string>& args) const {
    return rejuv::test_support::run_rejuv(dir_, args);
  }
};

const std::string kGraph = (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string();
const std::string kPolicy = (kRepo / "policies" / "quad_sr.policy.pbtxt").string();

struct Command {
  std::vector<std::string> name;      // "sweep", "merge"
  std::vector<std::string> operands;  // what makes the rest of the line valid
  std::string help_shows;             // a line of its --help made from the table
  std::vector<std::string> out_of_range;
  std::string range_error;
  std::string needs_value;            // an option given without its value
};

const std::vector<Command> kCommands = {
    {{"audit"}, {kPolicy}, "--format text|json", {"--format", "yaml"}, "--format: expected text or json, got 'yaml'",
     "--launch"},
    {{"run"}, {kGraph}, "--duration S", {"--duration", "0"}, "--duration: expected a number in (0, 1e+06), got '0'",
     "--seed"},
    {{"sim"}, {kGraph}, "--trace compact|full", {"--seed", "-3"}, "--seed: expected a non-negative integer, got '-3'",
     "--csv"},
    {{"gcs"}, {}, "--timeout SECONDS", {"--port", "0"}, "--port: expected an integer in 1..65535, got '0'", "--host"},
    {{"bench"}, {"images"}, "(1..100000; default 200)", {"--cycles", "0"},
     "--cycles: expected an integer in 1..100000, got '0'", "--restarts"},
    {{"report"}, {"table", kGraph}, "--domain N", {"--domain", "233"}, "--domain: expected an integer in 0..232, got '233'",
     "--out"},
    {{"faults"}, {kGraph}, "(1..16; default 1)", {"--jobs", "17"}, "--jobs: expected an integer in 1..16, got '17'",
     "--charge"},
    {{"soak"}, {kGraph}, "(1..10000000; default 1000)", {"--net-port", "65536"},
     "--net-port: expected an integer in 0..65535, got '65536'", "--cycles"},
    {{"sweep"}, {kGraph, "--param", "sr.t_mc_s=0.2"}, "--runner sim|run|both", {"--attacks", "100001"},
     "--attacks: expected an integer in 0..100000, got '100001'", "--seeds"},
    {{"sweep", "merge"}, {"somewhere"}, "--out DIR", {"--out="}, "option '--out' needs a non-empty value DIR", "--out"},
    {{"keys", "hosts"}, {"somewhere", "--launch", kGraph}, "--domain N", {"--domain", "233"},
     "--domain: expected an integer in 0..232, got '233'", "--domain"},
};

std::string joined(const std::vector<std::string>& words) {
  std::string s;
  for (const std::string& w : words) s += (s.empty() ? "" : " ") + w;
  return s;
}

TEST_F(CliCommands, HelpOfEveryCommandExit0FromItsTable) {
  for (const Command& c : kCommands) {
    std::vector<std::string> args = c.name;
    args.emplace_back("--help");
    const auto r = rejuv(args);
    EXPECT_EQ(r.exit_code, 0) << joined(c.name) << r.err;
    EXPECT_EQ(r.out.rfind("usage: rejuv " + joined(c.name), 0), 0U) << r.out;
    EXPECT_NE(r.out.find(c.help_shows), std::string::npos) << c.help_shows << "\n" << r.out;
    EXPECT_NE(r.out.find("  --help                show this help"), std::string::npos) << r.out;
  }
}

TEST_F(CliCommands, WrongFlagExit2NamesIt) {
  for (const Command& c : kCommands) {
    std::vector<std::string> args = c.name;
    args.insert(args.end(), c.operands.begin(), c.operands.end());
    args.emplace_back("--no-such-flag");
    const auto r = rejuv(args);
    EXPECT_EQ(r.exit_code, 2) << joined(args);
    EXPECT_NE(r.err.find("rejuv " + joined(c.name) + ": unknown option '--no-such-flag' for 'rejuv " + joined(c.name) +
                         "'"),
              std::string::npos)
        << r.err;
  }
}

TEST_F(CliCommands, ValueOutOfRangeExit2SaysTheRange) {
  for (const Command& c : kCommands) {
    std::vector<std::string> args = c.name;
    args.insert(args.end(), c.operands.begin(), c.operands.end());
    args.insert(args.end(), c.out_of_range.begin(), c.out_of_range.end());
    const auto r = rejuv(args);
    EXPECT_EQ(r.exit_code, 2) << joined(args);
    EXPECT_NE(r.err.find("rejuv " + joined(c.name) + ": " + c.range_error), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;  // refused before any work
  }
}

TEST_F(CliCommands, MissingValueExit2) {
  for (const Command& c : kCommands) {
    std::vector<std::string> args = c.name;
    args.insert(args.end(), c.operands.begin(), c.operands.end());
    args.push_back(c.needs_value);
    const auto r = rejuv(args);
    EXPECT_EQ(r.exit_code, 2) << joined(args);
    EXPECT_NE(r.err.find("option '" + c.needs_value + "' needs a value"), std::string::npos) << r.err;
  }
}

}  // namespace
