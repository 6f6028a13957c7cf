// Launch-graph loader (docs/design.md §1, §10): the shipped graph loads, and each class of semantic error is
// refused with the file:line:column of the offending field (docs/conventions.md "Errors are values").
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <google/protobuf/util/message_differencer.h>

#include "rejuv/launch/launch.hpp"

namespace rejuv::launch {
namespace {

// A virtual file beside the real launch graphs, so that the relative policy path resolves to the repo's.
const std::filesystem::path kAsPath =
    std::filesystem::path(REJUV_SOURCE_DIR) / "launch" / "unit_test.launch.pbtxt";

constexpr std::string_view kGood =
    R"pb(name: "unit"
policy: "../policies/quad_sr.policy.pbtxt"
services {
  name: "a"
  executable: "rejuv_a"
  uses { object: "x" rights: "R" }
  params { name: "gain" number: 2 }
}
services {
  name: "b"
  executable: "rejuv_b"
}
plant { executable: "rejuv_plant" physics_rate_hz: 1000 }
dds {
  bridges { topic: "x" direction: BRIDGE_IN }
  bridges { topic: "y" direction: BRIDGE_OUT }
}
sr {
  enabled: true
  t_mc_s: 0.3
  t_est_s: 3
  rho_m: 0.1
  rho_s: 0.09
  t_min_s: 0.02
  check_period_s: 0.002
  keep_generations: 2
  box { position_m: 0.5 velocity_m_s: 1 angle_rad: 0.35 rate_rad_s: 2 }
  restricted_limit_fraction: 0.3
}
mission {
  waypoints { north_m: 0 east_m: 0 down_m: -3 }
  acceptance_radius_m: 0.05
  timeout_s: 60
}
attack {
  enabled: true
  attacks { kind: WORST_CASE_CONTROL service: "a" }
}
)pb";

// The good graph with `from` replaced by `to`, and where `to` starts (1-based line and column).
struct Mutated {
  std::string text;
  int line = 0;
  int column = 0;
};

Mutated mutate(std::string_view from, std::string_view to) {
  std::string text(kGood);
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: \"" << from << "\" not in the base graph";
  if (at == std::string::npos) {
    return {text, 0, 0};
  }
  text.replace(at, from.size(), to);
  Mutated m{text, 1, 1};
  for (std::size_t i = 0; i < at; ++i) {
    if (text[i] == '\n') {
      ++m.line;
      m.column = 1;
    } else {
      ++m.column;
    }
  }
  return m;
}

// Parses the mutated graph and checks that it is refused as Semantic at the mutated field.
void expect_semantic_at(std::string_view from, std::string_view to, std::string_view message_part,
                        bool check_column = true) {
  const Mutated m = mutate(from, to);
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value()) << "accepted: " << to;
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic) << r.error().to_string();
  EXPECT_EQ(r.error().where.file, kAsPath.string());
  EXPECT_EQ(r.error().where.line, m.line) << r.error().to_string();
  if (check_column) {
    EXPECT_EQ(r.error().where.column, m.column) << r.error().to_string();
  }
  EXPECT_NE(r.error().message.find(message_part), std::string::npos) << r.error().to_string();
}

// launch/quad_square is the paper's square with the scheme of docs/control.md §6.3, and the held-out missions
// are that square with their own mission and wind: nothing else may drift from the paper's file.
TEST(LaunchLoader, TheSchemeAndTheHeldOutMissions_DifferFromThePapersSquareOnlyWhereTheySay) {
  const std::filesystem::path dir = std::filesystem::path(REJUV_SOURCE_DIR) / "launch";
  const auto paper = load_launch(dir / "quad_square_paper.launch.pbtxt");
  const auto scheme = load_launch(dir / "quad_square.launch.pbtxt");
  ASSERT_TRUE(paper.has_value()) << paper.error().to_string();
  ASSERT_TRUE(scheme.has_value()) << scheme.error().to_string();
  EXPECT_TRUE(scheme->graph.sr().estimate_catch_up());
  const auto as_paper = [&](proto::Launch g) {
    g.set_name(paper->graph.name());
    g.clear_policy();
    *g.mutable_sr() = paper->graph.sr();
    *g.mutable_mission() = paper->graph.mission();
    g.mutable_plant()->set_wind_mean_m_s(paper->graph.plant().wind_mean_m_s());
    g.mutable_plant()->set_wind_gust_m_s(paper->graph.plant().wind_gust_m_s());
    g.mutable_plant()->set_wind_toward_deg(paper->graph.plant().wind_toward_deg());
    return g;
  };
  proto::Launch reference = paper->graph;
  reference.clear_policy();
  google::protobuf::util::MessageDifferencer same;
  std::string diff;
  same.ReportDifferencesToString(&diff);
  EXPECT_TRUE(same.Compare(as_paper(scheme->graph), reference)) << diff;
  for (const char* held_out : {"held_out/pentagon_5m.launch.pbtxt", "held_out/zigzag_2m.launch.pbtxt"}) {
    const auto g = load_launch(dir / held_out);
    ASSERT_TRUE(g.has_value()) << g.error().to_string();
    EXPECT_EQ(g->policy_path, paper->policy_path) << held_out;
    EXPECT_GT(g->graph.plant().wind_mean_m_s(), 0.0) << held_out;
    EXPECT_NE(g->graph.mission().waypoints(0).down_m(), paper->graph.mission().waypoints(0).down_m()) << held_out;
    diff.clear();
    EXPECT_TRUE(same.Compare(g->graph.sr(), scheme->graph.sr())) << held_out << ": the scheme's sr\n" << diff;
    diff.clear();
    EXPECT_TRUE(same.Compare(as_paper(g->graph), reference)) << held_out << "\n" << diff;
  }
}

TEST(LaunchLoader, ShippedQuadSquare_Loads) {
  const auto r = load_launch(std::filesystem::path(REJUV_SOURCE_DIR) / "launch" / "quad_square_paper.launch.pbtxt");
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(r->graph.name(), "quad_square_paper");
  EXPECT_EQ(r->policy_path.filename(), "quad_sr.policy.pbtxt");
  EXPECT_TRUE(std::filesystem::is_regular_file(r->policy_path));
  EXPECT_NE(find_service(r->graph, "output_driver"), nullptr);
  EXPECT_FALSE(rejuvenate(*find_service(r->graph, "output_driver")));
}

// Several files, as `rejuv run A B` gives them: one graph composed by the rules of `include`. The hover and the
// example service's fragment: the hover's services, the fragment's appended, each relative path from its file.
TEST(LaunchLoader, SeveralFiles_ComposedIntoOneGraph) {
  const std::filesystem::path src(REJUV_SOURCE_DIR);
  const std::vector<std::filesystem::path> files{src / "launch" / "hover.launch.pbtxt",
                                                 src / "examples" / "hello_service" / "hello_monitor.launch.pbtxt"};
  const auto r = load_launch(std::span<const std::filesystem::path>(files));
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  const auto hover = load_launch(files[0]);
  ASSERT_TRUE(hover.has_value()) << hover.error().to_string();
  EXPECT_EQ(r->graph.name(), hover->graph.name());
  EXPECT_EQ(r->graph.services_size(), hover->graph.services_size() + 1);
  EXPECT_NE(find_service(r->graph, "hello_monitor"), nullptr);
  EXPECT_NE(find_service(r->graph, "output_driver"), nullptr);
  EXPECT_EQ(r->policy_path, hover->policy_path);
}

// Two whole graphs both set `name` (and more): refused at the second file's line, naming it.
TEST(LaunchLoader, SeveralFilesSettingOneField_RefusedAtTheSecond) {
  const std::filesystem::path launch = std::filesystem::path(REJUV_SOURCE_DIR) / "launch";
  const std::vector<std::filesystem::path> files{launch / "hover.launch.pbtxt", launch / "quad_square_paper.launch.pbtxt"};
  const auto r = load_launch(std::span<const std::filesystem::path>(files));
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().to_string().find("quad_square_paper.launch.pbtxt:"), std::string::npos) << r.error().to_string();
}

TEST(LaunchLoader, GoodGraph_LoadsWithLocations) {
  const auto r = parse_launch(kGood, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(r->locations.locate({{"services", 1}}, "name").line, 10);
  EXPECT_EQ(
      r->policy_path,
      (std::filesystem::path(REJUV_SOURCE_DIR) / "policies" / "quad_sr.policy.pbtxt").lexically_normal());
}

// Every prefix of a valid graph either loads or is refused with a position; never a crash.
TEST(LaunchLoader, TruncatedGraph_RefusedWithPositionNeverCrashes) {
  int refused = 0;
  for (std::size_t cut = 0; cut < kGood.size(); cut += 7) {
    const auto r = parse_launch(kGood.substr(0, cut), kAsPath);
    if (!r.has_value()) {
      ++refused;
      EXPECT_GT(r.error().where.line, 0) << "cut at " << cut << ": " << r.error().to_string();
    }
  }
  EXPECT_GT(refused, 0);
}

TEST(LaunchLoader, MissingFile_CannotRead) {
  const auto r = load_launch("/nonexistent/none.launch.pbtxt");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::CannotRead);
}

TEST(LaunchLoader, UnknownField_SyntaxError) {
  const Mutated bad = mutate("  executable: \"rejuv_b\"\n", "  executable: \"rejuv_b\"\n  bogus: 1\n");
  const auto r = parse_launch(bad.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.line, bad.line + 1);
}

TEST(LaunchLoader, MisspeltField_SyntaxErrorSuggestsTheField) {
  const Mutated bad = mutate("t_mc_s: 0.3", "t_mcs: 0.3");
  const auto r = parse_launch(bad.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.line, bad.line);
  EXPECT_EQ(r.error().where.column, bad.column);
  EXPECT_NE(r.error().message.find("has no field named \"t_mcs\" (did you mean \"t_mc_s\"?)"), std::string::npos)
      << r.error().message;
}

TEST(LaunchLoader, MisspeltEnumValue_SyntaxErrorAtTheValueSuggestsIt) {
  const Mutated bad = mutate("kind: WORST_CASE_CONTROL", "kind: WORST_CASE_CONTRL");
  const auto r = parse_launch(bad.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.line, bad.line) << r.error().to_string();
  EXPECT_EQ(r.error().where.column, bad.column + 6) << r.error().to_string();  // at the value, after "kind: "
  EXPECT_NE(r.error().message.find("(did you mean \"WORST_CASE_CONTROL\"?)"), std::string::npos) << r.error().message;
}

TEST(LaunchLoader, FieldFarFromAnyName_NoSuggestion) {
  const auto r = parse_launch(mutate("t_mc_s: 0.3", "completely_else: 0.3").text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("has no field named"), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().message.find("did you mean"), std::string::npos) << r.error().message;
}

TEST(LaunchLoader, MissingClosingBrace_SaysWhatAndWhereTheBlockBegan) {
  std::string text(kGood);
  text.erase(text.rfind('}'));  // the attack block's closing brace, the last of the file
  const std::size_t open = text.find("attack {");
  const int line = static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(open), '\n')) + 1;
  const auto r = parse_launch(text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_NE(r.error().message.find("missing '}' at the end of the file: the block `attack {` opened at line " +
                                   std::to_string(line) + ", column 8 is never closed"),
            std::string::npos)
      << r.error().message;
}

TEST(LaunchLoader, PolicyMissingOfACopiedFile_NamedByItsAbsolutePath) {
  // A relative path, as a user gives it, to a copy where ../policies does not exist.
  const std::filesystem::path copy = std::filesystem::path("no_such_dir_of_a_copy") / "deeper" / "g.launch.pbtxt";
  const auto r = parse_launch(kGood, copy);
  ASSERT_FALSE(r.has_value());
  const std::string resolved =
      (std::filesystem::current_path() / "no_such_dir_of_a_copy" / "policies" / "quad_sr.policy.pbtxt").string();
  EXPECT_NE(r.error().message.find("(resolved to " + resolved + ")"), std::string::npos) << r.error().message;
}

TEST(LaunchLoader, MissingName_SemanticAtStartOfFile) {
  const Mutated m = mutate("name: \"unit\"\n", "");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, 1);
  EXPECT_NE(r.error().message.find("name"), std::string::npos);
}

TEST(LaunchLoader, DuplicateServiceName_Semantic) {
  expect_semantic_at("name: \"b\"", "name: \"a\"", "duplicate service");
}

TEST(LaunchLoader, EmptyServiceName_Semantic) {
  expect_semantic_at("name: \"b\"", "name: \"\"", "without a `name`");
}

TEST(LaunchLoader, ServiceNameWithSpace_Semantic) {
  expect_semantic_at("name: \"b\"", "name: \"b c\"", "letters");
}

TEST(LaunchLoader, EmptyExecutable_Semantic) {
  expect_semantic_at("executable: \"rejuv_b\"", "executable: \"\"", "executable");
}

TEST(LaunchLoader, UsesUnknownRightLetter_Semantic) {
  expect_semantic_at("rights: \"R\"", "rights: \"RX\"", "bad rights");
}

TEST(LaunchLoader, UsesRepeatedRightLetter_Semantic) {
  expect_semantic_at("rights: \"R\"", "rights: \"RR\"", "bad rights");
}

TEST(LaunchLoader, UsesEmptyRights_SemanticAtUse) {
  // An empty string is still written, so the location is the rights field itself.
  expect_semantic_at("rights: \"R\"", "rights: \"\"", "bad rights");
}

TEST(LaunchLoader, UsesSameObjectTwice_Semantic) {
  expect_semantic_at("  params { name: \"gain\"",
                     "  uses { object: \"x\" rights: \"W\" }\n  params { name: \"gain\"", "twice", false);
}

TEST(LaunchLoader, ParamWithoutValue_Semantic) {
  expect_semantic_at("name: \"gain\" number: 2", "name: \"gain\"", "no value");
}

TEST(LaunchLoader, SrTmcZero_Semantic) {
  expect_semantic_at("t_mc_s: 0.3", "t_mc_s: 0", "T_MC");
}

TEST(LaunchLoader, SrTestNegative_Semantic) {
  expect_semantic_at("t_est_s: 3", "t_est_s: -1", "T_est");
}

TEST(LaunchLoader, SrRhoSAboveRhoM_Semantic) {
  expect_semantic_at("rho_s: 0.09", "rho_s: 0.2", "rho_s < rho_m");
}

TEST(LaunchLoader, SrRhoSZero_Semantic) {
  expect_semantic_at("rho_s: 0.09", "rho_s: 0", "0 < rho_s");
}

TEST(LaunchLoader, SrRhoMAboveOne_Semantic) {
  expect_semantic_at("rho_m: 0.1", "rho_m: 1.5", "sr.rho_m: 1.5 is out of range; ρ_M is a fraction (0 < ρ_M ≤ 1)");
}

TEST(LaunchLoader, SrNotFinite_Semantic) {
  expect_semantic_at("t_est_s: 3", "t_est_s: inf", "finite");
}

TEST(LaunchLoader, SrNan_Semantic) {
  expect_semantic_at("t_min_s: 0.02", "t_min_s: nan", "finite");
}

TEST(LaunchLoader, SrCheckPeriodExplicitZero_Semantic) {
  expect_semantic_at("check_period_s: 0.002", "check_period_s: 0", "check_period_s");
}

TEST(LaunchLoader, SrKeepGenerationsExplicitZero_Semantic) {
  expect_semantic_at("keep_generations: 2", "keep_generations: 0", "keep_generations");
}

// K = 2 needs 1 + 2 × 3 = 7 processes per rejuvenated service (refused at load, not a failed image fork
// in flight). The error points at the limits line, the one after the executable.
void expect_limits_refused(std::string_view limits, std::string_view message_part) {
  const std::string exe = "  executable: \"rejuv_b\"\n";
  const Mutated m = mutate(exe, exe + std::string(limits));
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value()) << "accepted: " << limits;
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic) << r.error().to_string();
  EXPECT_EQ(r.error().where.line, m.line + 1) << r.error().to_string();
  EXPECT_NE(r.error().message.find(message_part), std::string::npos) << r.error().to_string();
}

TEST(LaunchLoader, MaxProcessesBelowWhatKeepGenerationsNeeds_Semantic) {
  expect_limits_refused("  limits { max_processes: 6 }\n",
                        "max_processes 6 of 'b' is too low for keep_generations 2: a rejuvenated service needs 7");
  const Mutated ok = mutate("  executable: \"rejuv_b\"\n", "  executable: \"rejuv_b\"\n  limits { max_processes: 7 }\n");
  EXPECT_TRUE(parse_launch(ok.text, kAsPath).has_value());
}

TEST(LaunchLoader, MaxOpenFilesBelowTheSdksNeed_Semantic) {
  expect_limits_refused("  limits { max_open_files: 8 }\n", "max_open_files must be at least 16");
}

TEST(LaunchLoader, MaxPublicationsPerSZero_Semantic) {
  expect_limits_refused("  limits { max_publications_per_s: 0 }\n", "max_publications_per_s must be 1..1000000");
}

TEST(LaunchLoader, MaxPublicationsPerSAboveTheBound_Semantic) {
  expect_limits_refused("  limits { max_publications_per_s: 1000001 }\n",
                        "max_publications_per_s must be 1..1000000 (publications per second of kernel time)");
}

TEST(LaunchLoader, MaxPublicationsPerS_ServiceOverGraphOverDefault) {
  const Mutated m = mutate("  executable: \"rejuv_b\"\n",
                           "  executable: \"rejuv_b\"\n  limits { max_publications_per_s: 50 }\n");
  auto r = parse_launch(m.text, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  proto::Launch g = r->graph;
  for (const proto::ServiceSpec& s : g.services()) {
    EXPECT_EQ(sandbox_limits(g, s).max_publications_per_s, s.name() == "b" ? 50U : defaults::kSandboxPublicationsPerS)
        << s.name();
  }
  g.mutable_sandbox_limits()->set_max_publications_per_s(300);
  for (const proto::ServiceSpec& s : g.services()) {
    EXPECT_EQ(sandbox_limits(g, s).max_publications_per_s, s.name() == "b" ? 50U : 300U) << s.name();
  }
}

TEST(LaunchLoader, SrBoxEntryZero_Semantic) {
  expect_semantic_at("angle_rad: 0.35", "angle_rad: 0", "sr.box.angle_rad");
}

TEST(LaunchLoader, SrRestrictedFractionAboveOne_Semantic) {
  expect_semantic_at("restricted_limit_fraction: 0.3", "restricted_limit_fraction: 1.5", "sr.restricted_limit_fraction: 1.5 is out of range; Ū is a fraction");
}

TEST(LaunchLoader, SrRestrictedFractionZero_Semantic) {
  expect_semantic_at("restricted_limit_fraction: 0.3", "restricted_limit_fraction: 0", "(0, 1]");
}

TEST(LaunchLoader, SrEkfRearmZeroStd_SemanticAtTheField) {
  expect_semantic_at("restricted_limit_fraction: 0.3",
                     "restricted_limit_fraction: 0.3 ekf_rearm { enabled: true position_std_m: 0 }",
                     "sr.ekf_rearm.position_std_m must be a finite 1-sigma > 0", false);
}

TEST(LaunchLoader, SrDisabled_ParametersNotChecked) {
  const Mutated m = mutate("  enabled: true\n  t_mc_s: 0.3", "  enabled: false\n  t_mc_s: -5");
  const auto r = parse_launch(m.text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}

TEST(LaunchLoader, SrDefaults_AppliedWhenUnset) {
  Mutated m = mutate("  check_period_s: 0.002\n  keep_generations: 2\n", "");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(keep_generations(r->graph.sr()), defaults::kKeepGenerations);
  EXPECT_DOUBLE_EQ(check_period(r->graph.sr()).count(), 0.002);
  EXPECT_DOUBLE_EQ(t_mc(r->graph.sr()).count(), 0.3);
}

TEST(LaunchLoader, MissionWithoutWaypoints_Semantic) {
  const Mutated m = mutate("  waypoints { north_m: 0 east_m: 0 down_m: -3 }\n", "");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, m.line - 1);  // the `mission {` line
  EXPECT_NE(r.error().message.find("1..16 waypoints"), std::string::npos);
}

TEST(LaunchLoader, MissionSeventeenWaypoints_Semantic) {
  std::string many;
  for (int i = 0; i < 17; ++i) {
    many += "  waypoints { north_m: " + std::to_string(i) + " }\n";
  }
  const Mutated m = mutate("  waypoints { north_m: 0 east_m: 0 down_m: -3 }\n", many);
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, m.line + 16);  // the 17th waypoint
  EXPECT_NE(r.error().message.find("got 17"), std::string::npos);
}

TEST(LaunchLoader, WaypointNotFinite_Semantic) {
  expect_semantic_at("down_m: -3", "down_m: -inf", "down_m");
}

TEST(LaunchLoader, AcceptanceRadiusZero_Semantic) {
  expect_semantic_at("acceptance_radius_m: 0.05", "acceptance_radius_m: 0", "acceptance_radius_m");
}

TEST(LaunchLoader, MissionTimeoutNegative_Semantic) {
  expect_semantic_at("timeout_s: 60", "timeout_s: -1", "timeout_s");
}

TEST(LaunchLoader, MissionTimeoutZero_SemanticSayingItCanBeLeftOut) {
  expect_semantic_at("timeout_s: 60", "timeout_s: 0", "leave it out to derive it from the path");
}

TEST(LaunchLoader, MissionTimeoutSet_Kept) {
  const auto r = parse_launch(kGood, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_DOUBLE_EQ(mission_timeout(r->graph.mission()).count(), 60.0);
}

// Unset: 60 s + 150 s per metre of the path, at least 600 s, so that a long mission is not cut off by a fixed 600 s.
TEST(LaunchLoader, MissionTimeoutUnset_DerivedFromThePath) {
  const auto timeout_of = [](std::string_view waypoints) {
    const Mutated m = mutate("timeout_s: 60", std::string(waypoints));
    auto r = parse_launch(m.text, kAsPath);
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
    return r ? std::optional{std::pair{path_length_m(r->graph.mission()), mission_timeout(r->graph.mission()).count()}}
             : std::nullopt;
  };
  // The shipped square's path, 4 m: 660 s.
  const auto square = timeout_of(
      "waypoints { north_m: 1 down_m: -3 } waypoints { north_m: 1 east_m: 1 down_m: -3 } "
      "waypoints { east_m: 1 down_m: -3 } waypoints { down_m: -3 }");
  ASSERT_TRUE(square);
  EXPECT_NEAR(square->first, 4.0, 1e-12);
  EXPECT_DOUBLE_EQ(square->second, 660.0);
  // A 10 m mission (the kind that took 640 s with SR): 1560 s, where a fixed 600 s would have ended it.
  const auto long_one = timeout_of("waypoints { north_m: 6 east_m: 8 down_m: -3 }");
  ASSERT_TRUE(long_one);
  EXPECT_DOUBLE_EQ(long_one->second, 60.0 + 150.0 * 10.0);
  // A hover: the floor.
  const auto hover = timeout_of("");
  ASSERT_TRUE(hover);
  EXPECT_DOUBLE_EQ(hover->second, 600.0);
}

TEST(LaunchLoader, AttackUnknownService_Semantic) {
  expect_semantic_at("service: \"a\"", "service: \"zz\"", "not in the graph");
}

TEST(LaunchLoader, AttackUnspecifiedKind_Semantic) {
  expect_semantic_at("kind: WORST_CASE_CONTROL", "kind: ATTACK_UNSPECIFIED", "kind");
}

TEST(LaunchLoader, PlantNegativeRate_Semantic) {
  expect_semantic_at("physics_rate_hz: 1000", "physics_rate_hz: -1", "physics_rate_hz");
}

TEST(LaunchLoader, PlantWindTowardAFullTurn_Semantic) {
  expect_semantic_at("physics_rate_hz: 1000", "physics_rate_hz: 1000 wind_toward_deg: 360", "wind_toward_deg",
                     false);
  expect_semantic_at("physics_rate_hz: 1000", "physics_rate_hz: 1000 wind_toward_deg: -90", "[0, 360)", false);
}

TEST(LaunchLoader, PlantZeroRate_DefaultsTo1kHz) {
  const Mutated m = mutate("physics_rate_hz: 1000", "physics_rate_hz: 0");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_DOUBLE_EQ(physics_rate_hz(r->graph.plant()), defaults::kPhysicsRateHz);
  EXPECT_DOUBLE_EQ(physics_step(r->graph.plant()).count(), 0.001);
}

TEST(LaunchLoader, BridgeSameTopicTwice_Semantic) {
  expect_semantic_at("topic: \"y\"", "topic: \"x\"", "bridged twice");
}

TEST(LaunchLoader, BridgeDefaultDdsName_IsPrefixed) {
  const auto r = parse_launch(kGood, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(dds_name(r->graph.dds(), r->graph.dds().bridges(0)), "rejuv/x");
}

TEST(LaunchLoader, BridgeRos2Names_RtPrefixedAndOwnNameKept) {
  const Mutated m = mutate("dds {", "dds { ros2_names: true");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(dds_naming(r->graph.dds()), DdsNaming::Ros2);
  EXPECT_EQ(dds_name(r->graph.dds(), r->graph.dds().bridges(0)), "rt/x");
  proto::Bridge own = r->graph.dds().bridges(0);
  own.set_dds_name("rt/vehicle/x");
  EXPECT_EQ(dds_name(r->graph.dds(), own), "rt/vehicle/x");
}

TEST(LaunchLoader, PolicyMissingFile_Semantic) {
  expect_semantic_at("policy: \"../policies/quad_sr.policy.pbtxt\"",
                     "policy: \"../policies/none.policy.pbtxt\"", "does not exist");
}

TEST(LaunchLoader, PolicyEmpty_Semantic) {
  expect_semantic_at("policy: \"../policies/quad_sr.policy.pbtxt\"", "policy: \"\"", "missing `policy`",
                     false);
}

TEST(LaunchLoader, DdsConfigMissing_Semantic) {
  expect_semantic_at("bridges { topic: \"x\"", "config: \"nope.xml\"\n  bridges { topic: \"x\"",
                     "DDS config");
}


// ---- launch values out of range or meaningless: refused at load ----

TEST(LaunchLoader, SrTestZero_Semantic) {
  expect_semantic_at("t_est_s: 3", "t_est_s: 0", "sr.t_est_s (T_est) must be > 0 s");
}
// ---- lockstep timing: the charge model and the alignment ----

TEST(LaunchLoader, LockstepUnset_DefaultsOfTheLoader) {
  const auto r = parse_launch(kGood, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(checkpoint_charge(r->graph.lockstep()), defaults::kCheckpointCharge);
  EXPECT_EQ(rollback_charge(r->graph.lockstep()), defaults::kRollbackCharge);
  EXPECT_EQ(alignment(r->graph.lockstep()), defaults::kAlignment);
}
TEST(LaunchLoader, LockstepSet_ValuesInSeconds) {
  const Mutated m = mutate("mission {", "lockstep { checkpoint_charge_ms: 2 rollback_charge_ms: 0 alignment_s: 0 }\nmission {");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_DOUBLE_EQ(checkpoint_charge(r->graph.lockstep()).count(), 0.002);
  EXPECT_DOUBLE_EQ(rollback_charge(r->graph.lockstep()).count(), 0.0);  // set to 0: no default
  EXPECT_DOUBLE_EQ(alignment(r->graph.lockstep()).count(), 0.0);
}
TEST(LaunchLoader, LockstepAlignmentNegative_Semantic) {
  expect_semantic_at("mission {", "lockstep { alignment_s: -1 }\nmission {", "lockstep.alignment_s must be 0 to 3600 s",
                     false);
}
TEST(LaunchLoader, LockstepCheckpointChargeNan_Semantic) {
  expect_semantic_at("mission {", "lockstep { checkpoint_charge_ms: nan }\nmission {",
                     "lockstep.checkpoint_charge_ms must be 0 to 1000 ms", false);
}
TEST(LaunchLoader, LockstepRollbackChargeHuge_Semantic) {
  expect_semantic_at("mission {", "lockstep { rollback_charge_ms: 1e9 }\nmission {",
                     "lockstep.rollback_charge_ms must be 0 to 1000 ms", false);
}

TEST(LaunchLoader, SrKeepGenerationsHuge_Semantic) {
  expect_semantic_at("keep_generations: 2", "keep_generations: 4294967295", "sr.keep_generations must be 1 to 16");
}
TEST(LaunchLoader, SrTmcHuge_Semantic) {
  expect_semantic_at("t_mc_s: 0.3", "t_mc_s: 1e308", "sr.t_mc_s: 1e+308 is 1e+308 s; T_MC is seconds (0 < T_MC ≤ 10 s)");
}
// ---- a value in another unit than the field's (ms for s, % for a fraction, km/h for m/s): refused with a hint ----

TEST(LaunchLoader, SrTmcInMilliseconds_RefusedWithTheSecondsItMeant) {
  expect_semantic_at("t_mc_s: 0.3", "t_mc_s: 200",
                     "sr.t_mc_s: 200 is 200 s; T_MC is seconds (0 < T_MC ≤ 10 s); did you mean 0.2 (200 ms)?");
}
TEST(LaunchLoader, SrTestInMilliseconds_RefusedWithTheSecondsItMeant) {
  expect_semantic_at("t_est_s: 3", "t_est_s: 50", "T_est is seconds (0 < T_est ≤ 10 s); did you mean 0.05 (50 ms)?");
}
TEST(LaunchLoader, SrTminInMilliseconds_RefusedWithTheSecondsItMeant) {
  expect_semantic_at("t_min_s: 0.02", "t_min_s: 20", "did you mean 0.02 (20 ms)?");
}
TEST(LaunchLoader, SrCheckPeriodInMilliseconds_RefusedWithTheSecondsItMeant) {
  expect_semantic_at("check_period_s: 0.002", "check_period_s: 2", "did you mean 0.002 (2 ms)?");
}
TEST(LaunchLoader, SrTmcBeyondAnyDesignNotMs_RefusedWithoutAHint) {
  expect_semantic_at("t_mc_s: 0.3", "t_mc_s: 20000", "T_MC is seconds (0 < T_MC ≤ 10 s)");
  const auto r = parse_launch(mutate("t_mc_s: 0.3", "t_mc_s: 20000").text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().message.find("did you mean"), std::string::npos) << r.error().message;  // 20 s is no T_MC either
}
TEST(LaunchLoader, SrRhoMInPercent_RefusedWithTheFractionItMeant) {
  expect_semantic_at("rho_m: 0.1", "rho_m: 10", "sr.rho_m: 10 is out of range; ρ_M is a fraction (0 < ρ_M ≤ 1); did you mean 0.1 (10 %)?");
}
TEST(LaunchLoader, WindInKmPerHour_RefusedWithTheMetresPerSecondItMeant) {
  expect_semantic_at("physics_rate_hz: 1000", "physics_rate_hz: 1000 wind_mean_m_s: 36",
                     "plant.wind_mean_m_s: 36 is 36 m/s; wind is metres per second (0 ≤ wind ≤ 30 m/s); did you mean 10 "
                     "(36 km/h)?", false);
}
TEST(LaunchLoader, AlignmentInMilliseconds_RefusedWithTheSecondsItMeant) {
  expect_semantic_at("mission {", "lockstep { alignment_s: 20000 }\nmission {", "did you mean 20 (20000 ms)?", false);
}
TEST(LaunchLoader, MissionTimeoutInMilliseconds_RefusedWithTheSecondsItMeant) {
  expect_semantic_at("timeout_s: 60", "timeout_s: 600000", "did you mean 600 (600000 ms)?");
}
TEST(LaunchLoader, SrRangesAtTheirBounds_Load) {
  std::string text = mutate("t_mc_s: 0.3", "t_mc_s: 10").text;
  for (const auto& [from, to] : {std::pair{"t_est_s: 3", "t_est_s: 10"}, {"t_min_s: 0.02", "t_min_s: 1"},
                                 {"check_period_s: 0.002", "check_period_s: 0.1"}, {"rho_m: 0.1", "rho_m: 1"}}) {
    text.replace(text.find(from), std::string_view(from).size(), to);
  }
  const auto r = parse_launch(text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}
TEST(LaunchLoader, ShippedGraphs_LoadWithinThePlausibleRanges) {
  const std::filesystem::path dir = std::filesystem::path(REJUV_SOURCE_DIR) / "launch";
  int n = 0;
  for (const auto& sub : {dir, dir / "held_out"}) {
    for (const auto& e : std::filesystem::directory_iterator(sub)) {
      if (!e.path().string().ends_with(".launch.pbtxt")) continue;
      const auto g = load_launch(e.path());
      EXPECT_TRUE(g.has_value()) << g.error().to_string();
      ++n;
    }
  }
  EXPECT_GT(n, 3);
}

TEST(LaunchLoader, SrCheckPeriodBelowANanosecondTick_Semantic) {
  expect_semantic_at("check_period_s: 0.002", "check_period_s: 1e-300", "sr.check_period_s must be at least");
}
TEST(LaunchLoader, ClockUnknownNumber_Semantic) {
  expect_semantic_at("services {\n  name: \"a\"", "clock: 99\nservices {\n  name: \"a\"", "unknown `clock` 99");
}
TEST(LaunchLoader, AttackKindUnknownNumber_Semantic) {
  expect_semantic_at("kind: WORST_CASE_CONTROL", "kind: 99", "unknown attack `kind` 99");
}
TEST(LaunchLoader, BridgeDirectionUnknownNumber_Semantic) {
  expect_semantic_at("direction: BRIDGE_OUT", "direction: 7", "unknown bridge `direction` 7");
}
TEST(LaunchLoader, PlantRateTiny_Semantic) {
  expect_semantic_at("physics_rate_hz: 1000", "physics_rate_hz: 1e-06", "plant.physics_rate_hz must be 100 to 100000 Hz");
}
TEST(LaunchLoader, PlantRateHuge_Semantic) {
  expect_semantic_at("physics_rate_hz: 1000", "physics_rate_hz: 1e12", "plant.physics_rate_hz must be 100 to 100000 Hz");
}
TEST(LaunchLoader, WaypointFarAway_Semantic) {
  expect_semantic_at("north_m: 0 east_m: 0 down_m: -3", "north_m: 1e300 east_m: 0 down_m: -3",
                     "north_m must be within");
}
TEST(LaunchLoader, WaypointBelowTheGround_Semantic) {
  expect_semantic_at("down_m: -3", "down_m: 5", "waypoint 0 is below the ground");
}
TEST(LaunchLoader, GraphNameInvalidUtf8_Semantic) {
  expect_semantic_at("name: \"unit\"", "name: \"un\\377it\"", "is not valid UTF-8");
}
TEST(LaunchLoader, ParamTextInvalidUtf8_Semantic) {
  expect_semantic_at("params { name: \"gain\" number: 2 }", "params { name: \"gain\" text: \"\\300\\200\" }",
                     "parameter text is not valid UTF-8", false);
}
TEST(LaunchLoader, ParamTextValidUtf8_Loads) {
  const Mutated m = mutate("params { name: \"gain\" number: 2 }", "params { name: \"label\" text: \"ρ_s ✓\" }");
  const auto r = parse_launch(m.text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}

// docs/design.md §9: a plan naming a kind the service has no hook for is refused at load, naming what it supports.
TEST(LaunchLoader, AttackKindWithoutHookInTheService_SemanticNamesSupportedKinds) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_safety_control\"");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  const std::size_t kind_at = m.text.find("kind: WORST_CASE_CONTROL");
  const int kind_line = static_cast<int>(std::count(m.text.begin(), m.text.begin() + static_cast<long>(kind_at), '\n')) + 1;
  EXPECT_EQ(r.error().where.line, kind_line) << r.error().to_string();
  EXPECT_NE(r.error().message.find("has no hook for WORST_CASE_CONTROL"), std::string::npos) << r.error().to_string();
  EXPECT_NE(r.error().message.find("supports: none"), std::string::npos) << r.error().to_string();
}
TEST(LaunchLoader, AttackKindWithoutHook_ListsTheRuntimeKindsOfAHookedService) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_checkpoint_p\"");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("INVOKE_CHECKPOINT, ARM_TIMER"), std::string::npos) << r.error().to_string();
}
// The real-time plan (docs/realtime.md): a service's SCHED_FIFO priority must stay below the kernel's, which rolls it back.
TEST(LaunchLoader, RtPriorityAtTheKernels_SemanticAtTheField) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_a\"\n  rt_priority: 60");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, m.line + 1) << r.error().to_string();  // the rt_priority line
  EXPECT_NE(r.error().message.find("must be below the kernel's (realtime.kernel_priority 60)"), std::string::npos)
      << r.error().to_string();
}
TEST(LaunchLoader, RtPriorityBelowTheKernels_Loads) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_a\"\n  rt_priority: 59");
  const auto r = parse_launch(m.text + "realtime { enabled: true kernel_priority: 60 }\n", kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}
TEST(LaunchLoader, RealtimeKernelPriorityOutOfRange_Semantic) {
  const auto r = parse_launch(std::string(kGood) + "realtime { enabled: true kernel_priority: 100 }\n", kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("kernel_priority must be 2..99"), std::string::npos) << r.error().to_string();
}
// CPU pinning (docs/realtime.md): a CPU number a cpu_set_t cannot hold is refused at its field; any other loads
// (a CPU the machine lacks is the run's to report, not the loader's).
TEST(LaunchLoader, ServiceCpuBeyondCpuSetSize_SemanticAtTheField) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_a\"\n  cpu: 1024");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, m.line + 1) << r.error().to_string();  // the cpu line
  EXPECT_NE(r.error().message.find("must be 0..1023, got 1024"), std::string::npos) << r.error().to_string();
}
TEST(LaunchLoader, ServiceCpuAndPlanCpus_Load) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_a\"\n  cpu: 1023");
  const auto r = parse_launch(m.text + "realtime { enabled: true kernel_cpu: 0 plant_cpu: 1 }\n", kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}
TEST(LaunchLoader, RealtimePlantCpuBeyondCpuSetSize_Semantic) {
  const auto r = parse_launch(std::string(kGood) + "realtime { enabled: true plant_cpu: 4096 }\n", kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("plant_cpu must be 0..1023, got 4096"), std::string::npos) << r.error().to_string();
}
// ekf2 installs the runtime hooks, so a plan may compromise it with a helper process at boot.
TEST(LaunchLoader, EscapeHelperOnEkf2_Loads) {
  Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_ekf2\"");
  const std::size_t kind_at = m.text.find("kind: WORST_CASE_CONTROL");
  ASSERT_NE(kind_at, std::string::npos);
  m.text.replace(kind_at, std::string_view("kind: WORST_CASE_CONTROL").size(), "kind: ESCAPE_HELPER");
  const auto r = parse_launch(m.text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}
TEST(LaunchLoader, EscapeHelperOnAServiceWithoutHooks_Semantic) {
  Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_safety_control\"");
  const std::size_t kind_at = m.text.find("kind: WORST_CASE_CONTROL");
  ASSERT_NE(kind_at, std::string::npos);
  m.text.replace(kind_at, std::string_view("kind: WORST_CASE_CONTROL").size(), "kind: ESCAPE_HELPER");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("has no hook for ESCAPE_HELPER"), std::string::npos) << r.error().to_string();
}
// CUSTOM (the SDK's hook, rejuv/sdk/attack_hook.hpp): loads for a service outside the in-tree table (its
// author installs the hook), refused for an in-tree service, which has none, saying what CUSTOM is for.
TEST(LaunchLoader, CustomOnAServiceOutsideTheTree_Loads) {
  Mutated m = mutate("kind: WORST_CASE_CONTROL", "kind: CUSTOM");  // on "a" (rejuv_a: not in the table)
  const auto r = parse_launch(m.text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}
TEST(LaunchLoader, CustomOnAnInTreeService_SemanticAtTheKind) {
  for (const char* exe : {"rejuv_ekf2", "rejuv_lqr_control", "rejuv_safety_control"}) {
    Mutated m = mutate("executable: \"rejuv_a\"", std::string("executable: \"") + exe + "\"");
    const std::size_t kind_at = m.text.find("kind: WORST_CASE_CONTROL");
    ASSERT_NE(kind_at, std::string::npos);
    m.text.replace(kind_at, std::string_view("kind: WORST_CASE_CONTROL").size(), "kind: CUSTOM");
    const int kind_line =
        static_cast<int>(std::count(m.text.begin(), m.text.begin() + static_cast<long>(kind_at), '\n')) + 1;
    const auto r = parse_launch(m.text, kAsPath);
    ASSERT_FALSE(r.has_value()) << exe;
    EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
    EXPECT_EQ(r.error().where.line, kind_line) << r.error().to_string();
    EXPECT_NE(r.error().message.find("has no hook for CUSTOM"), std::string::npos) << r.error().to_string();
    EXPECT_NE(r.error().message.find("rejuv/sdk/attack_hook.hpp"), std::string::npos)
        << r.error().to_string();
  }
}
// The attack library (docs/control.md "Attack library"): each kind loads on the service that carries its hook,
// is refused on another, and its magnitude must be a size >= 0.
TEST(LaunchLoader, AttackLibraryKindOnItsService_LoadsElsewhereSemantic) {
  const std::pair<const char*, const char*> kinds[] = {{"ESTIMATE_SHIFT", "rejuv_ekf2"},
                                                       {"ESTIMATE_DRIFT", "rejuv_ekf2"},
                                                       {"SENSOR_BIAS", "rejuv_sensors"},
                                                       {"SETPOINT_SHIFT", "rejuv_gen_set_point"},
                                                       {"GAIN_OVERWRITE", "rejuv_lqr_control"}};
  for (const auto& [kind, executable] : kinds) {
    for (const char* exe : {executable, "rejuv_safety_control"}) {
      Mutated m = mutate("executable: \"rejuv_a\"", std::string("executable: \"") + exe + "\"");
      const std::size_t kind_at = m.text.find("kind: WORST_CASE_CONTROL");
      ASSERT_NE(kind_at, std::string::npos);
      m.text.replace(kind_at, std::string_view("kind: WORST_CASE_CONTROL").size(), std::string("kind: ") + kind);
      const auto r = parse_launch(m.text, kAsPath);
      if (std::string_view(exe) == executable) {
        EXPECT_TRUE(r.has_value()) << kind << " on " << exe << ": " << r.error().to_string();
      } else {
        ASSERT_FALSE(r.has_value()) << kind << " on " << exe;
        EXPECT_NE(r.error().message.find(std::string("has no hook for ") + kind), std::string::npos)
            << r.error().to_string();
      }
    }
  }
}
TEST(LaunchLoader, AttackMagnitudeNegativeOrNotFinite_Semantic) {
  for (const char* bad : {"-1", "inf", "nan", "2e6"}) {
    Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_lqr_control\"");
    const std::size_t kind_at = m.text.find("kind: WORST_CASE_CONTROL");
    ASSERT_NE(kind_at, std::string::npos);
    m.text.insert(kind_at, std::string("magnitude: ") + bad + " ");
    const auto r = parse_launch(m.text, kAsPath);
    ASSERT_FALSE(r.has_value()) << bad;
    EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic) << r.error().to_string();
    EXPECT_NE(r.error().message.find("magnitude"), std::string::npos) << r.error().to_string();
  }
}
TEST(LaunchLoader, AttackKindTheServiceHooks_Loads) {
  const Mutated m = mutate("executable: \"rejuv_a\"", "executable: \"rejuv_lqr_control\"");
  const auto r = parse_launch(m.text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
}

// The network gate's MAVLink 2 signing key (docs/mavlink.md "Signing"): 32 bytes as 64 hex digits, or a
// file of them that only its owner may read; anything else is refused at the field.
TEST(LaunchLoader, SigningKeyNotHex_SemanticAtTheKey) {
  expect_semantic_at("attack {", "network { signing_key: \"00112233\" }\nattack {", "64 hex digits", false);
}

TEST(LaunchLoader, SigningKeyOf64HexDigits_Loads) {
  const Mutated m = mutate("attack {", "network { signing_key: \"" + std::string(64, 'a') + "\" }\nattack {");
  const auto r = parse_launch(m.text, kAsPath);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  const auto key = signing_key(r->graph.network(), r->path);
  ASSERT_TRUE(key.has_value() && key->has_value());
  EXPECT_EQ((*key)->bytes[0], 0xAA);
}

TEST(LaunchLoader, SigningKeyFileReadableByOthers_Semantic) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("rejuv_launch_key_" + std::to_string(::getpid()));
  {
    std::ofstream out(file);
    out << std::string(64, '1') << "\n";
  }
  std::filesystem::permissions(file, std::filesystem::perms::owner_read | std::filesystem::perms::others_read);
  expect_semantic_at("attack {", "network { signing_key_file: \"" + file.string() + "\" }\nattack {",
                     "group or others", false);
  std::filesystem::permissions(file, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  const Mutated m = mutate("attack {", "network { signing_key_file: \"" + file.string() + "\" }\nattack {");
  const auto r = parse_launch(m.text, kAsPath);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
  std::filesystem::remove(file);
}

TEST(LaunchLoader, GroundAddressWithoutPort_SemanticAtTheAddress) {
  expect_semantic_at("attack {", "network { ground_address: \"127.0.0.1\" }\nattack {", "IPv4 address and a port", false);
  expect_semantic_at("attack {", "network { ground_address: \"localhost:14550\" }\nattack {", "IPv4 address", false);
  expect_semantic_at("attack {", "network { ground_address: \"10.0.0.256:14550\" }\nattack {", "IPv4 address", false);
  const Mutated m = mutate("attack {", "network { ground_address: \"127.0.0.1:14550\" }\nattack {");
  EXPECT_TRUE(parse_launch(m.text, kAsPath).has_value());
}

}  // namespace
}  // namespace rejuv::launch
