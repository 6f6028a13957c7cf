// The typed option layer (tools/rejuv/args.hpp): one table parses, checks and writes the help.
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "args.hpp"

namespace rejuv::cli {
namespace {

enum class Color : std::uint8_t { Red, Green, Blue };

// A command with one option of each type.
struct Table {
  std::string graph;
  bool loud = false;
  std::uint64_t jobs = 1;
  std::optional<std::uint64_t> seed;
  double bound = 2.5;
  std::optional<double> duration;
  std::string host = "localhost";
  std::filesystem::path out = "out/x";
  Color color = Color::Green;
  std::optional<std::pair<int, int>> shard;
  std::vector<std::string> params;
  Options opts{"demo", "A demo command."};

  Table() {
    opts.positional("GRAPH", graph, "the graph")
        .flag("--loud", loud, "say more")
        .integer("--jobs", "J", jobs, {1, 16}, "jobs side by side")
        .integer("--seed", "N", seed, {}, "the seed", "the graph's")
        .real("--bound", "K", bound, {.min = 0}, "a bound [kB]")
        .real("--duration", "S", duration, {.min = 0, .max = 1e6, .open_min = true, .open_max = true}, "how long")
        .text("--host", "IP", host, "where")
        .path("--out", "DIR", out, "output")
        .choice<Color>("--color", {{"red", Color::Red}, {"green", Color::Green}, {"blue", Color::Blue}}, color, "hue")
        .custom<std::pair<int, int>>(
            "--shard", "i/n", shard,
            [](std::string_view t) -> Result<std::pair<int, int>, std::string> {
              if (t == "1/2") return std::pair{1, 2};
              return fail("--shard: expected i/n, got '" + std::string(t) + "'");
            },
            "a shard")
        .repeated("--param", "P", params, "a parameter");
  }

  Result<ParseOutcome, std::string> parse(std::vector<std::string_view> args) { return opts.parse(args); }
};

TEST(Options, EveryTypeParsesAndDefaultsStayUntilGiven) {
  Table t;
  ASSERT_TRUE(t.parse({"g.pbtxt"}));
  EXPECT_EQ(t.graph, "g.pbtxt");
  EXPECT_EQ(t.jobs, 1U);
  EXPECT_FALSE(t.seed);
  EXPECT_FALSE(t.opts.given("--jobs"));
  Table u;
  const auto r = u.parse({"g", "--loud", "--jobs", "16", "--seed=7", "--bound", "0", "--duration", "1e5", "--host",
                          "10.0.0.1", "--out", "o", "--color", "blue", "--shard", "1/2", "--param", "a=1", "--param",
                          "b=2"});
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(*r, ParseOutcome::Run);
  EXPECT_TRUE(u.loud);
  EXPECT_EQ(u.jobs, 16U);
  EXPECT_EQ(u.seed, 7U);
  EXPECT_EQ(u.bound, 0.0);
  EXPECT_EQ(u.duration, 1e5);
  EXPECT_EQ(u.host, "10.0.0.1");
  EXPECT_EQ(u.out, "o");
  EXPECT_EQ(u.color, Color::Blue);
  EXPECT_EQ(u.shard, (std::pair{1, 2}));
  EXPECT_EQ(u.params, (std::vector<std::string>{"a=1", "b=2"}));
  EXPECT_TRUE(u.opts.given("--jobs"));
}

// Arguments and the one error they get.
struct Refused {
  std::vector<std::string_view> args;
  std::string error;
};

TEST(Options, BadValuesGetOneErrorFormatNamingTheOption) {
  const std::vector<Refused> cases = {
      {{"g", "--strict"}, "unknown option '--strict' for 'rejuv demo' (see 'rejuv demo --help')"},
      {{"g", "--jobs"}, "option '--jobs' needs a value J (see 'rejuv demo --help')"},
      {{"g", "--jobs="}, "option '--jobs' needs a non-empty value J (see 'rejuv demo --help')"},
      {{"g", "--loud=1"}, "option '--loud' takes no value (see 'rejuv demo --help')"},
      {{"g", "--jobs", "0"}, "--jobs: expected an integer in 1..16, got '0'"},
      {{"g", "--jobs", "17"}, "--jobs: expected an integer in 1..16, got '17'"},
      {{"g", "--jobs", "-1"}, "--jobs: expected an integer in 1..16, got '-1'"},
      {{"g", "--jobs", "2x"}, "--jobs: expected an integer in 1..16, got '2x'"},
      {{"g", "--seed", "x"}, "--seed: expected a non-negative integer, got 'x'"},
      {{"g", "--bound", "-1"}, "--bound: expected a number >= 0, got '-1'"},
      {{"g", "--bound", "nan"}, "--bound: expected a number >= 0, got 'nan'"},
      {{"g", "--duration", "0"}, "--duration: expected a number in (0, 1e+06), got '0'"},
      {{"g", "--duration", "inf"}, "--duration: expected a number in (0, 1e+06), got 'inf'"},
      {{"g", "--color", "pink"}, "--color: expected red, green or blue, got 'pink'"},
      {{"g", "--shard", "3/2"}, "--shard: expected i/n, got '3/2'"},
      {{}, "missing argument GRAPH (see 'rejuv demo --help')"},
      {{"g", "h"}, "unexpected argument 'h' (see 'rejuv demo --help')"},
  };
  for (const Refused& c : cases) {
    Table t;
    const auto r = t.parse(c.args);
    ASSERT_FALSE(r) << c.error;
    EXPECT_EQ(r.error(), c.error);
  }
}

// A single-valued option given twice would silently lose one (`--seed 1 --seed 2` flew seed 2, two --attack
// flew the last): refused, naming it; a repeated() option collects every value.
TEST(Options, AnOptionGivenTwice_IsRefusedUnlessItCollects) {
  Table t;
  const auto twice = t.parse({"g", "--seed", "1", "--seed", "2"});
  ASSERT_FALSE(twice.has_value());
  EXPECT_NE(twice.error().find("'--seed' given twice"), std::string::npos) << twice.error();
  Table f;
  EXPECT_FALSE(f.parse({"g", "--loud", "--loud"}).has_value());
  Table r;
  ASSERT_TRUE(r.parse({"g", "--param", "a=1", "--param", "b=2"}).has_value());
  EXPECT_EQ(r.params, (std::vector<std::string>{"a=1", "b=2"}));
}

// A value forgotten before the next option (`--ulog --no-figures` wrote a 65 MB file named '--no-figures'):
// refused, naming both; a value that begins with '--' is given with '='.
TEST(Options, AnotherOptionInPlaceOfAValue_IsRefused) {
  Table t;
  const auto r = t.parse({"g", "--out", "--loud"});
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().find("'--out' needs a value DIR, got the option '--loud'"), std::string::npos) << r.error();
  EXPECT_FALSE(t.loud);
  Table h;
  EXPECT_FALSE(h.parse({"g", "--host", "--help"}).has_value());
  Table e;
  ASSERT_TRUE(e.parse({"g", "--out=--loud"}).has_value());
  EXPECT_EQ(e.out, std::filesystem::path("--loud"));
  Table n;  // a word that only looks like an option, and no option of the command: a value
  ASSERT_TRUE(n.parse({"g", "--host", "--not-an-option"}).has_value());
  EXPECT_EQ(n.host, "--not-an-option");
}

// A required option: the usage line shows it without brackets, and its absence is refused by name.
TEST(Options, RequiredOption_ShownWithoutBracketsAndItsAbsenceRefused) {
  std::string graph;
  std::vector<std::string> params;
  Options o("demo", "A demo.");
  o.positional("GRAPH", graph, "the graph").repeated("--param", "P", params, "a parameter").required();
  const std::vector<std::string_view> none{"g"};
  const auto r = o.parse(none);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().find("missing option --param P"), std::string::npos) << r.error();
  EXPECT_NE(o.help().find("usage: rejuv demo --param P ..."), std::string::npos) << o.help();
}

TEST(Options, HelpIsWrittenFromTheTable) {
  Table t;
  const auto r = t.parse({"g", "--help"});
  ASSERT_TRUE(r);
  EXPECT_EQ(*r, ParseOutcome::HelpShown);
  const std::string help = t.opts.help();
  EXPECT_EQ(help.rfind("usage: rejuv demo [--loud] [--jobs J] [--seed N]", 0), 0U) << help;
  for (const char* line : {"  GRAPH                 the graph\n",
                           "  --jobs J              jobs side by side (1..16; default 1)\n",
                           "  --seed N              the seed (default: the graph's)\n",
                           "  --bound K             a bound [kB] (K >= 0; default 2.5)\n",
                           "  --duration S          how long (0 < S < 1e+06)\n",
                           "  --host IP             where (default localhost)\n",
                           "  --out DIR             output (default out/x)\n",
                           "  --color red|green|blue hue (default green)\n",
                           "  --shard i/n           a shard\n",
                           "  --help                show this help\n"}) {
    EXPECT_NE(help.find(line), std::string::npos) << line << "\n" << help;
  }
}

// The help's range and default are the parser's: the bounds of the table are accepted, one beyond refused.
TEST(Options, HelpAndParserAgreeOnBounds) {
  for (const auto& [value, ok] : std::array{std::pair{"1", true}, std::pair{"16", true}, std::pair{"0", false},
                                            std::pair{"17", false}}) {
    Table t;
    EXPECT_EQ(t.parse({"g", "--jobs", value}).has_value(), ok) << value;
  }
}

}  // namespace
}  // namespace rejuv::cli
