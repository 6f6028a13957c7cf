// Declared parameters (launch.hpp "declared parameters", idl/params.proto): a service's `params` in a launch graph
// are checked against the `<executable>.params.pbtxt` beside its executable — a misspelt name, a value of the
// wrong type or out of range is refused at the launch file's line:column, with "did you mean"; a declaration file
// is itself checked at its own file:line; every in-tree service declares its parameters and every shipped graph
// passes the check.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/launch/launch.hpp"

namespace rejuv::launch {
namespace {

const std::filesystem::path kSource(REJUV_SOURCE_DIR);
const std::filesystem::path kServiceDir = std::filesystem::path(REJUV_BINARY_DIR) / "bin";
// A virtual file beside the real launch graphs, so that the relative policy path resolves to the repo's.
const std::filesystem::path kAsPath = kSource / "launch" / "params_test.launch.pbtxt";
const std::filesystem::path kDeclPath = "rejuv_geofence.params.pbtxt";

constexpr std::string_view kDecls = R"pb(service: "geofence"
params {
  name: "x_max_m"
  type: NUMBER
  min: 0
  max: 1000
  min_exclusive: true
  default_number: 10
  unit: "m"
  help: "north limit"
}
params { name: "count" type: INTEGER min: 1 max: 16 default_number: 4 help: "how many" }
params { name: "strict" type: BOOL default_number: 1 help: "refuse rather than clamp" }
params { name: "shape" type: TEXT choices: "box" choices: "disc" default_text: "box" help: "fence shape" }
params { name: "label" type: TEXT help: "free text" }
)pb";

// A graph whose service "fence" (executable rejuv_geofence) has `params_lines` (each line "  params { … }\n").
std::string graph_with(std::string_view params_lines) {
  return std::string(R"pb(name: "params_test"
policy: "../policies/quad_sr.policy.pbtxt"
services {
  name: "other"
  executable: "rejuv_other"
}
services {
  name: "fence"
  executable: "rejuv_geofence"
)pb") + std::string(params_lines) + "}\nmission { waypoints { down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 60 }\n";
}
constexpr int kFirstParamLine = 10;  // the line of the first of `params_lines` in graph_with

LoadedParams decls() {
  auto d = parse_params_file(kDecls, kDeclPath);
  EXPECT_TRUE(d.has_value()) << d.error().to_string();
  return std::move(*d);
}

// The check of service "fence" (index 1) of graph_with(params_lines).
Result<void, LoadError> check(std::string_view params_lines) {
  auto g = parse_launch(graph_with(params_lines), kAsPath);
  EXPECT_TRUE(g.has_value()) << g.error().to_string();
  if (!g) return fail(g.error());
  return check_service_params(*g, 1, decls());
}

// The refusal of `params_line` (the only param) at line kFirstParamLine, column `column`, with `message_part`.
void expect_refused_at(std::string_view params_line, int column, std::string_view message_part) {
  const auto r = check(params_line);
  ASSERT_FALSE(r.has_value()) << "accepted: " << params_line;
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.file, kAsPath.string());
  EXPECT_EQ(r.error().where.line, kFirstParamLine) << r.error().to_string();
  EXPECT_EQ(r.error().where.column, column) << r.error().to_string();
  EXPECT_NE(r.error().message.find(message_part), std::string::npos) << r.error().to_string();
}

// Column of `field` in `line` (1-based), where the refusal points.
int column_of(std::string_view line, std::string_view field) { return static_cast<int>(line.find(field)) + 1; }

TEST(LaunchParams, DeclaredValues_Accepted) {
  const auto r = check(
      "  params { name: \"x_max_m\" number: 12.5 }\n  params { name: \"count\" number: 16 }\n"
      "  params { name: \"strict\" number: 0 }\n  params { name: \"shape\" text: \"disc\" }\n"
      "  params { name: \"label\" text: \"anything\" }\n");
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}

TEST(LaunchParams, MisspeltName_RefusedAtItsLineColumnWithSuggestion) {
  constexpr std::string_view kLine = "  params { name: \"xmax_m\" number: 12 }\n";
  expect_refused_at(kLine, column_of(kLine, "name"), "has no parameter \"xmax_m\" (did you mean \"x_max_m\"?)");
  const auto r = check(kLine);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("service \"fence\""), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(kDeclPath.string()), std::string::npos) << r.error().message;
}

TEST(LaunchParams, UnknownNameFarFromAny_RefusedWithoutSuggestion) {
  const auto r = check("  params { name: \"colour\" number: 1 }\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().message.find("did you mean"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("it declares x_max_m, count, strict, shape, label"), std::string::npos)
      << r.error().message;
}

TEST(LaunchParams, AboveMax_RefusedAtTheValue) {
  constexpr std::string_view kLine = "  params { name: \"x_max_m\" number: 2000 }\n";
  expect_refused_at(kLine, column_of(kLine, "number"), "2000 m is out of range: expected (0, 1000] m");
}

TEST(LaunchParams, AtExclusiveMin_RefusedAtTheValue) {
  constexpr std::string_view kLine = "  params { name: \"x_max_m\" number: 0 }\n";
  expect_refused_at(kLine, column_of(kLine, "number"), "out of range");
}

TEST(LaunchParams, TextForNumber_RefusedAtTheValue) {
  constexpr std::string_view kLine = "  params { name: \"x_max_m\" text: \"12\" }\n";
  expect_refused_at(kLine, column_of(kLine, "text"), "expected a number (`number: …`), got the text \"12\"");
}

TEST(LaunchParams, NumberForText_RefusedAtTheValue) {
  constexpr std::string_view kLine = "  params { name: \"shape\" number: 1 }\n";
  expect_refused_at(kLine, column_of(kLine, "number"), "expected a text");
}

TEST(LaunchParams, FractionForInteger_RefusedAtTheValue) {
  constexpr std::string_view kLine = "  params { name: \"count\" number: 2.5 }\n";
  expect_refused_at(kLine, column_of(kLine, "number"), "expected a whole number, got 2.5");
}

TEST(LaunchParams, TwoForBool_RefusedAtTheValue) {
  constexpr std::string_view kLine = "  params { name: \"strict\" number: 2 }\n";
  expect_refused_at(kLine, column_of(kLine, "number"), "expected 0 or 1");
}

TEST(LaunchParams, TextNotAChoice_RefusedWithSuggestion) {
  constexpr std::string_view kLine = "  params { name: \"shape\" text: \"dics\" }\n";
  expect_refused_at(kLine, column_of(kLine, "text"), "\"dics\" is not one of box|disc (did you mean \"disc\"?)");
}

// ---- the declaration file itself ----

void expect_decl_refused(std::string_view text, int line, std::string_view message_part) {
  const auto r = parse_params_file(text, kDeclPath);
  ASSERT_FALSE(r.has_value()) << "accepted: " << text;
  EXPECT_EQ(r.error().where.file, kDeclPath.string());
  EXPECT_EQ(r.error().where.line, line) << r.error().to_string();
  EXPECT_NE(r.error().message.find(message_part), std::string::npos) << r.error().to_string();
}

TEST(LaunchParamsFile, BadSyntax_RefusedAtItsOwnLine) {
  const auto r = parse_params_file("service: \"x\"\nparams {\n  name: \"a\"\n  tpye: NUMBER\n}\n", kDeclPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.file, kDeclPath.string());
  EXPECT_EQ(r.error().where.line, 4) << r.error().to_string();
  EXPECT_NE(r.error().to_string().find(kDeclPath.string() + ":4:"), std::string::npos) << r.error().to_string();
}

TEST(LaunchParamsFile, DuplicateName_Refused) {
  expect_decl_refused("params { name: \"a\" help: \"h\" }\nparams { name: \"a\" help: \"h\" }\n", 2, "declared twice");
}

TEST(LaunchParamsFile, MissingHelp_Refused) {
  expect_decl_refused("params { name: \"a\" }\n", 1, "no `help`");
}

TEST(LaunchParamsFile, MinAboveMax_Refused) {
  expect_decl_refused("params {\n  name: \"a\"\n  min: 2\n  max: 1\n  help: \"h\"\n}\n", 4, "the range [2, 1] is empty");
}

TEST(LaunchParamsFile, DefaultOutOfItsRange_Refused) {
  expect_decl_refused("params {\n  name: \"a\"\n  max: 1\n  default_number: 3\n  help: \"h\"\n}\n", 4,
                      "the default: 3 is out of range");
}

TEST(LaunchParamsFile, ChoicesOnANumber_Refused) {
  expect_decl_refused("params {\n  name: \"a\"\n  choices: \"x\"\n  help: \"h\"\n}\n", 3, "`choices` are for a TEXT");
}

TEST(LaunchParamsFile, DefaultTextNotAChoice_Refused) {
  expect_decl_refused("params {\n  name: \"a\"\n  type: TEXT\n  choices: \"x\"\n  default_text: \"y\"\n  help: \"h\"\n}\n",
                      5, "\"y\" is not one of x");
}

TEST(LaunchParamsFile, Table_ListsNameTypeDefaultRangeUnitHelp) {
  const std::string table = format_declared_params(decls().decls);
  EXPECT_NE(table.find("NAME"), std::string::npos) << table;
  for (const char* part : {"x_max_m", "number", "10", "(0, 1000]", " m ", "north limit", "count", "integer", "[1, 16]",
                           "strict", "bool", "0 or 1", "shape", "\"box\"", "box|disc", "fence shape"}) {
    EXPECT_NE(table.find(part), std::string::npos) << part << " not in\n" << table;
  }
}

// ---- the file beside the executable ----

class LaunchParamsDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("rejuv_params_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::filesystem::path dir_;
};

TEST_F(LaunchParamsDir, ExecutableWithoutDeclarations_NotChecked) {
  auto g = parse_launch(graph_with("  params { name: \"anything\" text: \"goes\" }\n"), kAsPath);
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto r = check_declared_params(*g, dir_);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}

TEST_F(LaunchParamsDir, ExecutableWithDeclarations_MisspeltNameRefusedAtTheLaunchLine) {
  std::ofstream(dir_ / "rejuv_geofence.params.pbtxt") << kDecls;
  auto g = parse_launch(graph_with("  params { name: \"xmax_m\" number: 12 }\n"), kAsPath);
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto r = check_declared_params(*g, dir_);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().to_string().rfind(kAsPath.string() + ":" + std::to_string(kFirstParamLine) + ":12: error: ", 0), 0U)
      << r.error().to_string();
  EXPECT_NE(r.error().message.find("did you mean \"x_max_m\""), std::string::npos) << r.error().message;
}

TEST_F(LaunchParamsDir, BrokenDeclarationFile_RefusedAtItsOwnLine) {
  std::ofstream(dir_ / "rejuv_geofence.params.pbtxt") << "params {\n  name: \"a\"\n  help: \"h\"\n  min: x\n}\n";
  auto g = parse_launch(graph_with(""), kAsPath);
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  const auto r = check_declared_params(*g, dir_);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.file, (dir_ / "rejuv_geofence.params.pbtxt").string());
  EXPECT_EQ(r.error().where.line, 4) << r.error().to_string();
}

// ---- the in-tree services and shipped graphs ----

std::vector<std::filesystem::path> files_ending(const std::filesystem::path& dir, std::string_view suffix,
                                                bool recursive) {
  std::vector<std::filesystem::path> out;
  const auto take = [&](const std::filesystem::path& p) {
    const std::string name = p.filename().string();
    if (name.size() > suffix.size() && name.ends_with(suffix)) out.push_back(p);
  };
  if (recursive) {
    for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) take(e.path());
  } else {
    for (const auto& e : std::filesystem::directory_iterator(dir)) take(e.path());
  }
  return out;
}

// Every service folder of services/ declares its parameters, and the build put each file beside its executable.
TEST(LaunchParamsInTree, EveryServiceDeclaresItsParameters_AndEachFileLoads) {
  std::set<std::string> sources;
  for (const auto& p : files_ending(kSource / "services", ".params.pbtxt", true)) {
    if (p.parent_path().filename() == "attacks") continue;  // the hooks' params, appended to the services' own
    sources.insert(p.filename().string());
    const auto r = load_params_file(p);
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
  }
  EXPECT_GE(sources.size(), 9U);
  for (const std::string& s : sources) {
    const std::filesystem::path built = kServiceDir / ("rejuv_" + s);
    const auto r = load_params_file(built);
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
    if (r) {
      EXPECT_EQ("rejuv_" + r->decls.service() + ".params.pbtxt", built.filename().string());
    }
  }
}

TEST(LaunchParamsInTree, ExtLink_DeclaresTelemetryPeriod) {
  const auto r = load_params_file(kServiceDir / "rejuv_ext_link.params.pbtxt");
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  bool found = false;
  for (const proto::ParamDecl& d : r->decls.params()) {
    if (d.name() != "telemetry_period_s") continue;
    found = true;
    EXPECT_EQ(d.type(), proto::NUMBER);
    EXPECT_DOUBLE_EQ(d.default_number(), 0.1);
    EXPECT_DOUBLE_EQ(d.min(), 0.01);
    EXPECT_DOUBLE_EQ(d.max(), 10.0);
  }
  EXPECT_TRUE(found);
}

// Every shipped graph stays valid: its params pass the check against the built declarations.
TEST(LaunchParamsInTree, ShippedGraphs_PassTheCheck) {
  const auto graphs = files_ending(kSource / "launch", ".launch.pbtxt", true);  // with launch/held_out
  EXPECT_FALSE(graphs.empty());
  for (const auto& path : graphs) {
    const auto g = load_launch(path);
    ASSERT_TRUE(g.has_value()) << g.error().to_string();
    const auto r = check_declared_params(*g, kServiceDir);
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
  }
}

// The out-of-tree example: its declaration file loads and its launch fragment's params, in the hover it is
// flown in, pass against it.
TEST(LaunchParamsInTree, HelloExample_ParamsPassItsDeclarations) {
  const auto d = load_params_file(kSource / "examples" / "hello_service" / "hello_monitor.params.pbtxt");
  ASSERT_TRUE(d.has_value()) << d.error().to_string();
  const auto g = parse_launch("include: \"../../launch/hover.launch.pbtxt\"\ninclude: \"hello_monitor.launch.pbtxt\"\n",
                              kSource / "examples" / "hello_service" / "unit_test.launch.pbtxt");
  ASSERT_TRUE(g.has_value()) << g.error().to_string();
  bool found = false;
  for (int i = 0; i < g->graph.services_size(); ++i) {
    if (g->graph.services(i).name() != "hello_monitor") continue;
    found = true;
    const auto r = check_service_params(*g, i, *d);
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
  }
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace rejuv::launch
