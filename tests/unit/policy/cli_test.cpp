// `rejuv audit` as a user runs it (docs/design.md §4, §10): the real binary, its exit codes (0 clean,
// 1 violations, 2 bad input), its compiler-style lines and a JSON document that a JSON parser accepts.
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../../rejuv_cli.hpp"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
using Outcome = rejuv::test_support::CliOutcome;

// A scratch folder for this process, removed at the end of each test.
class RejuvCli : public rejuv::test_support::ScratchDirTest {
 protected:
  RejuvCli() : ScratchDirTest("rejuv_cli_test_") {}

  // Runs `rejuv <args>` with stdout and stderr captured to files (no shell, no quoting issues).
  Outcome rejuv(const std::vector<std::string>& args) const { return ::rejuv::test_support::run_rejuv(dir_, args); }

  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
};

std::string example(std::string_view name) {
  return (kRepo / "policies" / "examples" / name).string();
}
const std::string kQuadSr = (kRepo / "policies" / "quad_sr.policy.pbtxt").string();
const std::string kQuadSquare = (kRepo / "launch" / "quad_square_paper.launch.pbtxt").string();

// Parses JSON with protobuf's own parser into a google.protobuf.Struct (fails on invalid JSON).
bool parse_json(const std::string& text, google::protobuf::Struct& out) {
  return google::protobuf::util::JsonStringToMessage(text, &out).ok();
}

TEST_F(RejuvCli, QuadSr_Exit0WithMatrixAndVerdict) {
  const Outcome r = rejuv({"audit", kQuadSr});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("UPDATE"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ext_link"), std::string::npos);
  EXPECT_NE(r.out.find("audit: OK"), std::string::npos) << r.out;
  EXPECT_TRUE(r.err.empty()) << r.err;
}

TEST_F(RejuvCli, QuadSrWithLaunch_Exit0) {
  const Outcome r = rejuv({"audit", kQuadSr, "--launch", kQuadSquare});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("with graph \"quad_square_paper\""), std::string::npos) << r.out;
}

TEST_F(RejuvCli, LaunchWithoutPolicy_AuditsThePolicyTheGraphNames) {
  const Outcome r = rejuv({"audit", "--launch", kQuadSquare});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("quad_sr.policy.pbtxt"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("with graph \"quad_square_paper\""), std::string::npos) << r.out;
  EXPECT_TRUE(r.err.empty()) << r.err;
}

// A graph across hosts: each host's links as `rejuv run --host` adds them, audited with the rest.
const std::string kCompanionDir = (kRepo / "tests" / "across_hosts").string();

TEST_F(RejuvCli, GraphAcrossHosts_ListsEachHostsLinksAndStaysClean) {
  const Outcome r = rejuv({"audit", "--launch", kCompanionDir + "/companion.launch.pbtxt"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("link: host \"vehicle\" runs link_companion (rejuv_host_link, MC only): waypoints W, state R"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("link: host \"companion\" runs link_vehicle (rejuv_host_link, MC only): state W, waypoints R"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("audit: OK"), std::string::npos) << r.out;
}

TEST_F(RejuvCli, SetpointCarriedByALink_RefusedByLateral) {
  // The planner may write the SETPOINT topic from the companion (remote_writers), but on the vehicle the link
  // that carries it is network-facing: `lateral` refuses its Write.
  std::ifstream in(kCompanionDir + "/companion.policy.pbtxt");
  std::stringstream text;
  text << in.rdbuf();
  std::string policy = text.str();
  const std::string plain = "objects { name: \"waypoints\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" }";
  ASSERT_NE(policy.find(plain), std::string::npos);
  policy.replace(policy.find(plain), plain.size(),
                 "objects { name: \"waypoints\" kind: TOPIC type: \"rejuv::msg::MissionWaypoints\" role: SETPOINT "
                 "remote_writers: \"planner\" }");
  write("companion.policy.pbtxt", policy);
  const auto graph = write("companion.launch.pbtxt", slurp(kCompanionDir + "/companion.launch.pbtxt"));
  const Outcome r = rejuv({"audit", "--launch", graph.string()});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("violation [lateral]: grant of \"W\" on \"waypoints\" (Topic) to \"link_companion\" in MC"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("has 1 violation(s) (lateral 1)"), std::string::npos) << r.out;
}

TEST_F(RejuvCli, TextMatrix_FitsIn100Columns) {
  const Outcome r = rejuv({"audit", kQuadSr});
  std::istringstream lines(r.out);
  std::string line;
  bool in_matrix = false;
  int rows = 0;
  while (std::getline(lines, line)) {
    in_matrix = in_matrix ? !line.empty() : line.starts_with("service ");
    if (!in_matrix) {
      continue;
    }
    ++rows;
    std::size_t columns = 0;
    for (const char c : line) {
      columns += (static_cast<unsigned char>(c) & 0xC0U) == 0x80U ? 0 : 1;  // UTF-8 continuation bytes
    }
    EXPECT_LE(columns, 100U) << line;
    EXPECT_FALSE(line.ends_with(" ")) << "trailing blanks: '" << line << "'";
  }
  EXPECT_GT(rows, 40);
}

// The 1-based line of `path` that its author marked with `marker` (after content, not in a comment).
int marked_line(const std::string& path, std::string_view marker) {
  std::ifstream in(path);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.find(marker) != std::string::npos && !line.starts_with("#")) {
      return n;
    }
  }
  return 0;
}

TEST_F(RejuvCli, BrokenExample_Exit1WithCompilerStyleLine) {
  const std::string path = example("timer_broken.policy.pbtxt");
  const Outcome r = rejuv({"audit", path});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  const int line = marked_line(path, "<- violation");
  ASSERT_GT(line, 0);
  EXPECT_NE(r.out.find(path + ":" + std::to_string(line) + ":1: violation [timer]: "), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("audit: FAILED"), std::string::npos) << r.out;
}

TEST_F(RejuvCli, DenyExample_Exit1NamesTheRule) {
  const Outcome r = rejuv({"audit", example("deny_broken.policy.pbtxt")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("violation [deny:only-driver-drives-motors]"), std::string::npos) << r.out;
}

TEST_F(RejuvCli, MalformedPolicy_Exit2ErrorWithPosition) {
  const std::string path = example("malformed_unknown_service.policy.pbtxt");
  const Outcome r = rejuv({"audit", path});
  EXPECT_EQ(r.exit_code, 2);
  const int line = marked_line(path, "<- error");
  ASSERT_GT(line, 0);
  EXPECT_NE(r.err.find(path + ":" + std::to_string(line) + ":10: error: unknown service \"lqr_controll\""),
            std::string::npos)
      << r.err;
}

TEST_F(RejuvCli, SyntaxError_Exit2) {
  const Outcome r = rejuv({"audit", example("malformed_unknown_field.policy.pbtxt")});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(":9:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("error:"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, MissingPolicyFile_Exit2) {
  const Outcome r = rejuv({"audit", (dir_ / "absent.policy.pbtxt").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no such file"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, BadLaunchFile_Exit2) {
  const auto graph = write("bad.launch.pbtxt", "name: \"x\"\nservices { bogus: 1 }\n");
  const Outcome r = rejuv({"audit", kQuadSr, "--launch", graph.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(graph.string() + ":2:"), std::string::npos) << r.err;
}

// An object a service `uses` that the policy does not declare is an unknown name: refused at the launch file's
// line with the object meant, exit 2 in `rejuv audit --launch` and in `rejuv run` (README "Exit codes").
TEST_F(RejuvCli, LaunchUsingAMisspeltObject_Exit2WithDidYouMean) {
  std::string text = slurp(kRepo / "launch" / "quad_square_paper.launch.pbtxt");
  const std::string rel = "\"../policies/quad_sr.policy.pbtxt\"";
  text.replace(text.find(rel), rel.size(), "\"" + kQuadSr + "\"");
  const std::string used = "object: \"vehicle_state\"";
  text.replace(text.find(used), used.size(), "object: \"vehicle_sate\"");
  const auto graph = write("typo.launch.pbtxt", text);
  for (const std::vector<std::string>& args : {std::vector<std::string>{"audit", "--launch", graph.string()},
                                               std::vector<std::string>{"run", graph.string()}}) {
    const Outcome r = rejuv(args);
    EXPECT_EQ(r.exit_code, 2) << args[0] << ": " << r.err;
    EXPECT_NE(r.err.find(graph.string() + ":"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("uses \"vehicle_sate\", which is no object of the policy"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(did you mean \"vehicle_state\"?)"), std::string::npos) << r.err;
  }
}

// A policy fragment that names a file its author could not read (`rejuv audit` as root): refused by name, exit 2,
// nothing of the file on the terminal; a FIFO as the policy neither blocks nor passes.
TEST_F(RejuvCli, PolicyIncludingAShadowLikeFileOrAFifo_Exit2NamingItWithoutItsText) {
  const auto shadow = write("shadow", "root:$y$j9T$secret:19000:0:99999:7:::\n");
  const auto policy = write("p.policy.pbtxt", "name: \"p\"\ninclude: \"shadow\"\n");
  Outcome r = rejuv({"audit", policy.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(policy.string() + ":2:1: error: cannot include \"" + shadow.string() + "\""), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("secret"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("secret"), std::string::npos) << r.out;

  const auto fifo = dir_ / "fifo.policy.pbtxt";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  r = rejuv({"audit", fifo.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(fifo.string() + ":1:1: error: not a regular file (a FIFO)"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, UnknownFlag_Exit2) {
  const Outcome r = rejuv({"audit", kQuadSr, "--strict"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--strict"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, BadFormat_Exit2) {
  const Outcome r = rejuv({"audit", kQuadSr, "--format", "yaml"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("yaml"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, NoPolicyArgument_Exit2) {
  const Outcome r = rejuv({"audit"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("POLICY"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, Help_Exit0) {
  const Outcome r = rejuv({"audit", "--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--launch"), std::string::npos) << r.out;
}

// `rejuv run --cpu N|all` (KernelOptions::placement): refused before anything is spawned.
TEST_F(RejuvCli, RunCpu_NotACpu_Exit2NamesTheFlag) {
  const Outcome r = rejuv({"run", kQuadSquare, "--cpu", "fast"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--cpu"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("fast"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, RunCpu_Unavailable_Exit2SaysWhich) {
  const Outcome r = rejuv({"run", kQuadSquare, "--cpu", "1023"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("CPU 1023 is not available"), std::string::npos) << r.err;
}

// README "Exit codes": an audit violation is exit 1 whichever command finds it. `rejuv run` audits the
// graph's policy before it starts anything.
TEST_F(RejuvCli, RunPolicyFailingTheAudit_Exit1LikeAudit) {
  std::string policy = slurp(kQuadSr);
  const std::string grant = "object: \"checkpoint\"              rights: \"W\"  modes: [RB, SC, UPDATE, CP]";
  ASSERT_NE(policy.find(grant), std::string::npos);
  policy.replace(policy.find(grant), grant.size(),
                 "object: \"checkpoint\"              rights: \"W\"  modes: [MC, RB, SC, UPDATE, CP]");
  const auto policy_path = write("p.policy.pbtxt", policy);
  std::string graph = slurp(kQuadSquare);
  const std::string rel = "policy: \"../policies/quad_sr.policy.pbtxt\"";
  graph.replace(graph.find(rel), rel.size(), "policy: \"" + policy_path.string() + "\"");
  const auto graph_path = write("g.launch.pbtxt", graph);
  const Outcome r = rejuv({"run", graph_path.string()});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("violation [timer]"), std::string::npos) << r.err;
  EXPECT_EQ(rejuv({"audit", policy_path.string()}).exit_code, 1);
}

// `rejuv run A B`: several graph files are one graph; two that set one field are refused (exit 2) at the second.
TEST_F(RejuvCli, RunTwoGraphsSettingOneField_Exit2AtTheSecond) {
  const std::string hover = (kRepo / "launch" / "hover.launch.pbtxt").string();
  const Outcome r = rejuv({"run", hover, kQuadSquare, "--duration", "1"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(kQuadSquare + ":"), std::string::npos) << r.err;
}

TEST_F(RejuvCli, RunHelp_ListsCpu) {
  const Outcome r = rejuv({"run", "--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--cpu N|all"), std::string::npos) << r.out;
}

TEST_F(RejuvCli, JsonClean_ValidDocumentOkTrue) {
  const Outcome r = rejuv({"audit", kQuadSr, "--launch", kQuadSquare, "--format", "json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  google::protobuf::Struct doc;
  ASSERT_TRUE(parse_json(r.out, doc)) << r.out;
  EXPECT_TRUE(doc.fields().at("ok").bool_value());
  EXPECT_EQ(doc.fields().at("findings").list_value().values_size(), 0);
  EXPECT_GT(doc.fields().at("matrix").list_value().values_size(), 40);
  const auto& row = doc.fields().at("matrix").list_value().values(0).struct_value().fields();
  EXPECT_EQ(row.at("service").string_value(), "sensors");
  EXPECT_EQ(row.at("modes").struct_value().fields().at("MC").string_value(), "R");
}

TEST_F(RejuvCli, JsonBroken_FindingsCarryInvariantAndPosition) {
  const std::string path = example("sei_broken.policy.pbtxt");
  const Outcome r = rejuv({"audit", path, "--format=json"});
  EXPECT_EQ(r.exit_code, 1);
  google::protobuf::Struct doc;
  ASSERT_TRUE(parse_json(r.out, doc)) << r.out;
  EXPECT_FALSE(doc.fields().at("ok").bool_value());
  const auto& findings = doc.fields().at("findings").list_value();
  ASSERT_EQ(findings.values_size(), 1);
  const auto& f = findings.values(0).struct_value().fields();
  EXPECT_EQ(f.at("invariant").string_value(), "sei");
  EXPECT_EQ(f.at("file").string_value(), path);
  EXPECT_EQ(f.at("line").number_value(), marked_line(path, "<- violation"));
  EXPECT_EQ(f.at("column").number_value(), 1);
  EXPECT_FALSE(f.at("message").string_value().empty());
}

TEST_F(RejuvCli, JsonMalformed_Exit2StillValidJson) {
  const Outcome r = rejuv({"audit", example("malformed_bad_rights.policy.pbtxt"), "--format", "json"});
  EXPECT_EQ(r.exit_code, 2);
  google::protobuf::Struct doc;
  ASSERT_TRUE(parse_json(r.out, doc)) << r.out;
  EXPECT_FALSE(doc.fields().at("ok").bool_value());
  EXPECT_EQ(doc.fields().at("error").struct_value().fields().at("kind").string_value(), "semantic");
}

TEST_F(RejuvCli, JsonEscaping_QuotesBackslashesControlCharsRoundTrip) {
  const auto p = write("esc.policy.pbtxt",
                       "name: \"a \\\"quoted\\\" \\\\ back\\nnew\\tline\\001\"\n"
                       "services { name: \"s\" }\n"
                       "objects { name: \"o\" kind: MODE }\n"
                       "grants { service: \"s\" object: \"o\" rights: \"W\" modes: [MC] }\n");
  const Outcome r = rejuv({"audit", p.string(), "--format", "json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  google::protobuf::Struct doc;
  ASSERT_TRUE(parse_json(r.out, doc)) << r.out;
  EXPECT_EQ(doc.fields().at("name").string_value(), "a \"quoted\" \\ back\nnew\tline\x01");
}

}  // namespace
