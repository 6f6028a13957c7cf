// `rejuv sim` as a user runs it (the real binary): exit codes, precise errors, the JSON summary; and the bad
// flags of `rejuv bench`, refused before anything is started.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "../../rejuv_cli.hpp"

namespace {

const std::string kRejuv = std::string(REJUV_BINARY_DIR) + "/tools/rejuv/rejuv";
const std::string kSquare = std::string(REJUV_SOURCE_DIR) + "/launch/quad_square_paper.launch.pbtxt";

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

Outcome run(const std::string& args, const std::string& command_name = "sim") {
  Outcome out;
  const std::string command = kRejuv + " " + command_name + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) out.output += buf;
  const int status = pclose(pipe);
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

class TempDir {
 public:
  TempDir() : path_(std::filesystem::temp_directory_path() / ("rejuv_sim_cli_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

TEST(SimCli, UnknownFlag_ExitsTwo) {
  const auto r = run(kSquare + " --fast");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("unknown option '--fast'"), std::string::npos) << r.output;
}

TEST(SimCli, BadSeed_ExitsTwo) {
  const auto r = run(kSquare + " --seed twelve");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--seed"), std::string::npos) << r.output;
}

TEST(SimCli, MissingGraph_ExitsTwo) { EXPECT_EQ(run("").exit_code, 2); }

TEST(BenchCli, BadFlags_ExitTwoNamingTheFlag) {
  for (const auto& [args, named] : {std::pair{"images --between 0", "--between"},
                                    std::pair{"images --between soon", "--between"},
                                    std::pair{"images --cycles -3", "--cycles"},
                                    std::pair{"images --restarts 100000", "--restarts"},
                                    std::pair{"everything", "unknown benchmark 'everything'"}}) {
    const auto r = run(args, "bench");
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_NE(r.output.find(named), std::string::npos) << args << ": " << r.output;
  }
}

TEST(SimCli, TableWithCsv_ExitsTwo) { EXPECT_EQ(run(kSquare + " --table --csv /dev/null").exit_code, 2); }

TEST(SimCli, MissingFile_ExitsTwo) {
  const auto r = run("/nonexistent/graph.launch.pbtxt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("error"), std::string::npos) << r.output;
}

TEST(SimCli, SyntaxErrorInLaunch_ExitsTwoWithFileLineColumn) {
  TempDir dir;
  const auto file = dir.path() / "bad.launch.pbtxt";
  std::ofstream(file) << "name: \"bad\"\nsr {\n  t_mc_s: soon\n}\n";
  const auto r = run(file.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find(file.string() + ":3:"), std::string::npos) << r.output;
}

TEST(SimCli, UnwritableSummary_ExitsTwo) {
  EXPECT_EQ(run(kSquare + " --summary-json /nonexistent/dir/s.json").exit_code, 2);
}

TEST(SimCli, SafeRun_ExitsZeroAndWritesJson) {
  TempDir dir;
  const auto json = dir.path() / "s.json";
  const auto r = run(kSquare + " --no-attack --seed 3 --summary-json " + json.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(json);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("\"runner\": \"sim\""), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("\"mission_completed\": true"), std::string::npos);
  EXPECT_NE(text.str().find("\"max_V\""), std::string::npos);  // proto field names kept
  EXPECT_NE(r.output.find("done:"), std::string::npos);        // the final progress line, even without a TTY
}

TEST(SimCli, AttackWithoutSr_ExitsOne) {
  const auto r = run(kSquare + " --no-sr");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("LEFT THE SAFETY SET"), std::string::npos) << r.output;
}

TEST(SimCli, Csv_HeaderAndOneRowPerControlPeriod) {
  TempDir dir;
  const auto csv = dir.path() / "trace.csv";
  const auto r = run(kSquare + " --no-sr --no-attack --csv " + csv.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(csv);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("t_s,n_m,e_m,d_m", 0), 0U) << header;
  std::size_t rows = 0;
  while (std::getline(in, line)) ++rows;
  EXPECT_GT(rows, 1000U);
}

}  // namespace

namespace {

// The estimate catch-up replays the plant's samples into the rejuvenated services that read them: a graph where a
// service that is not rejuvenated reads one is refused before any process starts (it would be handed those samples
// a second time), exit 2 at the field's line.
TEST(RunCli, EstimateCatchUp_ANonRejuvenatedReader_RefusedAtTheField) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("rejuv_catch_up_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::string text = rejuv::test_support::slurp(rejuv::test_support::kRepo / "launch/quad_square_paper.launch.pbtxt");
  // sensors at driver level in the graph and in a copy of its policy (the audit wants the two to agree).
  const std::string policy = "policy: \"../policies/quad_sr.policy.pbtxt\"";
  text.replace(text.find(policy), policy.size(), "policy: \"" + (dir / "p.policy.pbtxt").string() + "\"");
  const std::string sensors = "executable: \"rejuv_sensors\"";
  text.replace(text.find(sensors), sensors.size(), sensors + "\n  rejuvenate: false");
  std::string policy_text = rejuv::test_support::slurp(rejuv::test_support::kRepo / "policies/quad_sr.policy.pbtxt");
  const std::string declared = "services { name: \"sensors\" }";
  policy_text.replace(policy_text.find(declared), declared.size(), "services { name: \"sensors\" level: DRIVER }");
  std::ofstream(dir / "p.policy.pbtxt") << policy_text;
  std::ofstream(dir / "g.launch.pbtxt") << text;
  const fs::path graph = dir / "catch_up.launch.pbtxt";  // launch/quad_square extending the edited copy
  rejuv::test_support::write_extending("quad_square.launch.pbtxt", dir / "g.launch.pbtxt", graph);
  const Outcome run_outcome = run(graph.string() + " --duration 1 --domain 231", "run");
  fs::remove_all(dir);
  EXPECT_EQ(run_outcome.exit_code, 2) << run_outcome.output;
  EXPECT_NE(run_outcome.output.find("catch_up.launch.pbtxt:"), std::string::npos) << run_outcome.output;  // sr.estimate_catch_up
  EXPECT_NE(run_outcome.output.find("'sensors' reads 'sensor_gyro'"), std::string::npos) << run_outcome.output;
  EXPECT_NE(run_outcome.output.find("not rejuvenated"), std::string::npos) << run_outcome.output;
  EXPECT_EQ(run_outcome.output.find("services ready"), std::string::npos) << run_outcome.output;
}

}  // namespace
