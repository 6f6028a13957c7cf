// The SDK as a package (docs/writing_a_service.md): install it into a scratch prefix with
// `cmake --install --component sdk`, configure and build examples/hello_service out of the tree against it
// (find_package(Rejuv) only; its own topic type by rejuv_add_topics), then fly its graph — the installed hover
// with the example's fragments — with the service it built. And the same for a service `rejuv new service`
// wrote: its own multi-process test passes as written.
// Every step is the guide's, so the guide cannot rot without this test failing.
#include <gtest/gtest.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "summary.pb.h"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::run_program;
using rejuv::test_support::slurp;

const std::filesystem::path kBuild(REJUV_BINARY_DIR);
const std::filesystem::path kCmake(REJUV_CMAKE_COMMAND);
const std::filesystem::path kCtest(REJUV_CTEST_COMMAND);

class SdkPackage : public rejuv::test_support::ScratchDirTest {
 protected:
  SdkPackage() : ScratchDirTest("rejuv_sdk_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }  // the logs of the failed step

  // One step in its own log folder `dir_/<name>`.
  rejuv::test_support::CliOutcome step(const std::string& name, const std::filesystem::path& program,
                                       std::vector<std::string> args) const {
    const std::filesystem::path logs = dir_ / ("log_" + name);
    std::filesystem::create_directories(logs);
    return run_program(logs, program, std::move(args));
  }

  // 1. Install the SDK component into dir_/prefix.
  void install() const {
    auto installed = step("install", kCmake, {"--install", kBuild.string(), "--component", "sdk", "--prefix", prefix().string()});
    ASSERT_EQ(installed.exit_code, 0) << installed.out << installed.err;
    ASSERT_TRUE(std::filesystem::exists(prefix() / "lib" / "cmake" / "Rejuv" / "RejuvConfig.cmake")) << installed.out;
    ASSERT_TRUE(std::filesystem::exists(prefix() / "include" / "rejuv" / "sdk" / "run.hpp"));
    ASSERT_TRUE(std::filesystem::exists(prefix() / "share" / "rejuv" / "launch" / "hover.launch.pbtxt"))
        << "the project's graphs, for a graph to include";
    // The installed SDK carries no protobuf: no header of it names protobuf, no library of it is linked to it.
    EXPECT_FALSE(std::filesystem::exists(prefix() / "include" / "rejuv" / "textproto")) << "textproto is not the SDK's";
  }

  // 2. Configure and build a project out of the tree, with nothing but the installed package.
  void build(const std::filesystem::path& source, const std::filesystem::path& build_dir,
             std::vector<std::string> extra = {}) const {
    std::vector<std::string> args = {
        "-S", source.string(), "-B", build_dir.string(), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
        "-DCMAKE_PREFIX_PATH=" + prefix().string(), "-DCMAKE_CXX_COMPILER=" REJUV_CXX_COMPILER,
        "-DCMAKE_C_COMPILER=" REJUV_C_COMPILER,
        // the build's own flags (a sanitizer preset's SDK needs its runtime in the service too)
        "-DCMAKE_CXX_FLAGS=" REJUV_CXX_FLAGS, "-DCMAKE_C_FLAGS=" REJUV_C_FLAGS,
        "-DCMAKE_EXE_LINKER_FLAGS=" REJUV_EXE_LINKER_FLAGS};
    args.insert(args.end(), extra.begin(), extra.end());
    auto configured = step("configure", kCmake, std::move(args));
    ASSERT_EQ(configured.exit_code, 0) << configured.out << configured.err;
    auto built = step("build", kCmake, {"--build", build_dir.string()});
    ASSERT_EQ(built.exit_code, 0) << built.out << built.err;
  }

  // Where the SDK is installed (dir_ exists once the test has set up).
  [[nodiscard]] std::filesystem::path prefix() const { return dir_ / "prefix"; }
};

TEST_F(SdkPackage, ExampleServiceBuildsAgainstTheInstalledPackageAndFlies) {
  const std::filesystem::path example_build = dir_ / "build-hello";
  ASSERT_NO_FATAL_FAILURE(install());
  // The CUSTOM attack hook for a service's test build (Rejuv::sdk_attack).
  EXPECT_TRUE(std::filesystem::exists(prefix() / "include" / "rejuv" / "sdk" / "attack_hook.hpp"));
  ASSERT_NO_FATAL_FAILURE(build(kRepo / "examples" / "hello_service", example_build));
  // A test build of it turns the hooks on (docs/writing_a_service.md "Injecting a fault into your own
  // service"): its CUSTOM hook compiles and links against the installed package.
  ASSERT_NO_FATAL_FAILURE(build(kRepo / "examples" / "hello_service", dir_ / "build-hello-hooks",
                                {"-DREJUV_ATTACK_HOOKS=ON"}));
  const std::filesystem::path service = example_build / "hello_monitor";
  ASSERT_TRUE(std::filesystem::exists(service));
  // Its declared parameters (rejuv_add_service PARAMS) beside it, where the kernel checks the graph's params.
  EXPECT_NE(slurp(example_build / "hello_monitor.params.pbtxt").find("name: \"period_s\""), std::string::npos);

  // 3. The example's build wrote its graph: the installed hover and the example's fragments, which it includes.
  const std::filesystem::path graph = example_build / "hello.launch.pbtxt";
  ASSERT_NE(slurp(graph).find("include: \"" + (prefix() / "share" / "rejuv" / "launch" / "hover.launch.pbtxt").string()),
            std::string::npos)
      << slurp(graph);
  // The example's own topic type (hello.idl, rejuv_add_topics): the build printed its policy entry with the
  // struct's size and alignment as compiled; the graph includes it in its policy.
  EXPECT_NE(slurp(example_build / "hello_topics.types.pbtxt")
                .find("types { name: \"hello::Summary\" size_bytes: 24 align_bytes: 8 }"),
            std::string::npos)
      << slurp(example_build / "hello_topics.types.pbtxt");
  // The composed graph audits clean against the policy the graph names, with the fragments' grants.
  auto audited = rejuv::test_support::run_rejuv(
      dir_, {"audit", (prefix() / "share" / "rejuv" / "policies" / "quad_sr.policy.pbtxt").string(), "--launch",
             graph.string()});
  EXPECT_EQ(audited.exit_code, 0) << audited.out << audited.err;
  EXPECT_NE(audited.out.find("hello_monitor"), std::string::npos) << audited.out;

  // 4. Fly it: 5 s of hover with rejuvenation (the first MC window opens after T_est = 3 s in SC), logged
  // as ULog (the author's own type too: as its bytes, docs/ulog.md).
  const std::filesystem::path summary = dir_ / "summary.json";
  const std::filesystem::path ulg = dir_ / "hello.ulg";
  auto flown = rejuv::test_support::run_rejuv(
      dir_, {"run", graph.string(), "--duration", "5", "--domain", std::to_string(rejuv::test_support::kOwnDdsDomain),
             "--net-port", "0", "--summary-json", summary.string(), "--ulog", ulg.string()});
  const std::string log = flown.out + flown.err;
  EXPECT_EQ(flown.exit_code, 0) << log;
  // It booted, received the state estimates and published its own topic (its log line says both counts, and
  // a publish the kernel refused would have been logged as a warning and counted as a denial).
  const std::regex hello(R"(\[hello_monitor\][^\n]*hello: ([0-9]+) states received, ([0-9]+) published)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(log, m, hello)) << log;
  EXPECT_GT(std::stoull(m[1].str()), 0U) << log;
  EXPECT_GT(std::stoull(m[2].str()), 0U) << log;
  EXPECT_EQ(log.find("publishing monitor_state"), std::string::npos) << log;
  EXPECT_EQ(log.find("publishing hello_summary"), std::string::npos) << log;  // its own type, routed
  // Its on_restored ran in a restored incarnation (the run rolls back: checkpoints and rollbacks below).
  EXPECT_NE(log.find("hello: restored into epoch 1"), std::string::npos) << log;
  const std::string json = slurp(summary);
  ASSERT_FALSE(json.empty());
  EXPECT_NE(json.find("\"denials\": {}"), std::string::npos) << json;  // no denied invocation of any service
  // With rejuvenation on, the graph (hello_monitor with it) was checkpointed and rolled back.
  EXPECT_EQ(json.find("\"checkpoints\": \"0\""), std::string::npos) << json;
  // The ULog holds the author's topic (hello_summary, type hello::Summary): what hello_monitor published of it.
  rejuv::proto::RunSummary s;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json, &s).ok()) << json;
  EXPECT_GT(std::filesystem::file_size(ulg), 1000U);
  const auto logged = s.ulog().routed_by_topic().find("hello_summary");
  ASSERT_NE(logged, s.ulog().routed_by_topic().end()) << s.ulog().DebugString();
  EXPECT_GT(logged->second, 0U);
  const auto monitor = std::find_if(s.services().begin(), s.services().end(),
                                    [](const rejuv::proto::ServiceSummary& v) { return v.name() == "hello_monitor"; });
  ASSERT_NE(monitor, s.services().end());
  EXPECT_EQ(monitor->publishes_by_topic().at("hello_summary"), logged->second);
}

// `rejuv new service`: the files it writes build against the installed package, and the scaffold's own
// multi-process test (the real kernel flies the hover with the new service, rejuvenation on) passes as written.
TEST_F(SdkPackage, NewServiceScaffoldBuildsAndItsOwnTestFlies) {
  ASSERT_NO_FATAL_FAILURE(install());
  const std::filesystem::path source = dir_ / "geofence";
  auto made = rejuv::test_support::run_rejuv(dir_, {"new", "service", "geofence", "--out", source.string()});
  ASSERT_EQ(made.exit_code, 0) << made.out << made.err;
  for (const char* f : {"geofence.cpp", "geofence.idl", "geofence.params.pbtxt", "geofence.policy.pbtxt",
                        "geofence.launch.pbtxt", "geofence_flight.launch.pbtxt.in", "CMakeLists.txt"}) {
    EXPECT_TRUE(std::filesystem::exists(source / f)) << f << "\n" << made.out;
  }
  // Nothing is overwritten: a second scaffold into the same folder is refused.
  auto again = rejuv::test_support::run_rejuv(dir_, {"new", "service", "geofence", "--out", source.string()});
  EXPECT_EQ(again.exit_code, 2) << again.out << again.err;

  // Built in a folder others cannot search (0700, like root's home): the service's uid cannot reach the
  // binary by its path, and flies anyway (the kernel execs the file it opened). No -DREJUV_PROGRAM: the
  // package names the rejuv program built with it.
  std::filesystem::permissions(dir_, std::filesystem::perms::owner_all);
  const std::filesystem::path build_dir = source / "build";
  ASSERT_NO_FATAL_FAILURE(build(source, build_dir,
                                {"-DREJUV_DDS_DOMAIN=" + std::to_string(rejuv::test_support::kOwnDdsDomain)}));
  auto tested = step("ctest", kCtest, {"--test-dir", build_dir.string(), "--output-on-failure"});
  EXPECT_EQ(tested.exit_code, 0) << tested.out << tested.err;
  EXPECT_NE(tested.out.find("geofence_flies"), std::string::npos) << tested.out;
  EXPECT_NE(tested.out.find("100% tests passed"), std::string::npos) << tested.out;

  // Without a rejuv program the flight test is still there, and fails saying what to do.
  auto reconfigured = step("reconfigure", kCmake, {"-S", source.string(), "-B", build_dir.string(),
                                                   "-DREJUV_PROGRAM=" + (dir_ / "no_such_rejuv").string()});
  ASSERT_EQ(reconfigured.exit_code, 0) << reconfigured.out << reconfigured.err;
  auto without = step("ctest_without", kCtest, {"--test-dir", build_dir.string(), "--output-on-failure"});
  EXPECT_NE(without.exit_code, 0) << without.out;
  EXPECT_NE(without.out.find("geofence_flies"), std::string::npos) << without.out;
  EXPECT_NE(without.out.find("no rejuv program at"), std::string::npos) << without.out;
  EXPECT_NE(without.out.find("-DREJUV_PROGRAM="), std::string::npos) << without.out;

  // A misspelt parameter in the service's own fragment is refused before anything starts, at the fragment's
  // line and column, with the declared name suggested.
  const std::filesystem::path fragment = source / "geofence.launch.pbtxt";
  std::string text = slurp(fragment);
  const std::size_t at = text.find("params { name: \"period_s\"");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, std::string("params { name: \"period_s\"").size(), "params { name: \"periods\"");
  std::ofstream(fragment) << text;
  const int line = static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n')) + 1;
  auto refused = rejuv::test_support::run_rejuv(
      dir_, {"run", (build_dir / "geofence_flight.launch.pbtxt").string(), "--duration", "1", "--net-port", "0",
             "--domain", std::to_string(rejuv::test_support::kOwnDdsDomain)});
  EXPECT_EQ(refused.exit_code, 2) << refused.out << refused.err;
  EXPECT_NE(refused.err.find(fragment.string() + ":" + std::to_string(line) + ":"), std::string::npos)
      << "expected the error at " << fragment << ":" << line << "\n" << refused.err;
  EXPECT_NE(refused.err.find("did you mean \"period_s\""), std::string::npos) << refused.err;
}

}  // namespace
