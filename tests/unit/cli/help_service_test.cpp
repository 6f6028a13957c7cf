// Declared parameters as a user meets them (docs/writing_a_service.md "Declaring parameters"): `rejuv run
// --help-service NAME [GRAPH]` prints what a service declares; a misspelt param of a graph is refused at its
// launch file's line:column with "did you mean" (here through `rejuv audit --launch`, which loads the graph as
// `rejuv run` does; the run itself: tests/multiproc/boot_failure_test.cpp), exit 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../../rejuv_cli.hpp"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
using Outcome = rejuv::test_support::CliOutcome;

const std::string kGraph = (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string();
const std::string kPolicy = (kRepo / "policies" / "quad_sr.policy.pbtxt").string();

class CliHelpService : public rejuv::test_support::ScratchDirTest {
 protected:
  CliHelpService() : ScratchDirTest("rejuv_cli_help_service_test_") {}
  Outcome rejuv(const std::vector<std::string>& args) const { return rejuv::test_support::run_rejuv(dir_, args); }
};

TEST_F(CliHelpService, ExecutableName_ListsItsDeclaredParameters) {
  const Outcome r = rejuv({"run", "--help-service", "ext_link"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* part : {"rejuv_ext_link", "NAME", "telemetry_period_s", "number", "0.1", "[0.01, 10]", " s ",
                           "geofence.radius_m"}) {
    EXPECT_NE(r.out.find(part), std::string::npos) << part << " not in\n" << r.out;
  }
}

TEST_F(CliHelpService, ServiceOfAGraph_ListsItsDeclaredParameters) {
  const Outcome r = rejuv({"run", "--help-service", "commander", kGraph});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("geofence.min_altitude_m"), std::string::npos) << r.out;
}

TEST_F(CliHelpService, UnknownServiceOfAGraph_Exit2WithSuggestion) {
  const Outcome r = rejuv({"run", "--help-service", "ext_lnk", kGraph});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("has no service 'ext_lnk' (did you mean \"ext_link\"?)"), std::string::npos) << r.err;
}

TEST_F(CliHelpService, UnknownExecutable_Exit2) {
  const Outcome r = rejuv({"run", "--help-service", "no_such_service"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("no service executable 'no_such_service'"), std::string::npos) << r.err;
}

TEST_F(CliHelpService, RunWithoutGraph_Exit2) {
  const Outcome r = rejuv({"run"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("missing argument GRAPH"), std::string::npos) << r.err;
}

// quad_square_paper with a misspelt param on ext_link: refused at its line and column, with the declared name.
TEST_F(CliHelpService, MisspeltParamInAGraph_Exit2AtItsLineWithSuggestion) {
  std::string text = slurp(kGraph);
  const std::string rel = "policy: \"../policies/quad_sr.policy.pbtxt\"";
  text.replace(text.find(rel), rel.size(), "policy: \"" + kPolicy + "\"");
  const std::string exe = "executable: \"rejuv_ext_link\"\n";
  const std::size_t at = text.find(exe) + exe.size();
  text.insert(at, "  params { name: \"telemetry_perod_s\" number: 0.5 }\n");
  const int line = static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n')) + 1;
  const auto graph = dir_ / "g.launch.pbtxt";
  std::ofstream(graph) << text;
  const Outcome r = rejuv({"audit", kPolicy, "--launch", graph.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(graph.string() + ":" + std::to_string(line) + ":12: error: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(did you mean \"telemetry_period_s\"?)"), std::string::npos) << r.err;
}

}  // namespace
