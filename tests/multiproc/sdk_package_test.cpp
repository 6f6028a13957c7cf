// The SDK as a package (docs/writing_a_service.md): install it into a scratch prefix with
// `cmake --install --component sdk`, configure and build examples/hello_service out of the tree against it
// (find_package(Rejuv) only; its own topic type by rejuv_add_topics), then fly examples/hello_service/hello.launch.pbtxt
// with the service it built.
// Every step is the guide's, so the guide cannot rot without this test failing.
#include <gtest/gtest.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <filesystem>
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
};

TEST_F(SdkPackage, ExampleServiceBuildsAgainstTheInstalledPackageAndFlies) {
  const std::filesystem::path prefix = dir_ / "prefix";
  const std::filesystem::path example_build = dir_ / "build-hello";

  // 1. Install the SDK component.
  auto installed = step("install", kCmake, {"--install", kBuild.string(), "--component", "sdk", "--prefix", prefix.string()});
  ASSERT_EQ(installed.exit_code, 0) << installed.out << installed.err;
  ASSERT_TRUE(std::filesystem::exists(prefix / "lib" / "cmake" / "Rejuv" / "RejuvConfig.cmake")) << installed.out;
  ASSERT_TRUE(std::filesystem::exists(prefix / "include" / "rejuv" / "sdk" / "run.hpp"));
  // The installed SDK carries no protobuf: no header of it names protobuf, no library of it is linked to it.
  EXPECT_FALSE(std::filesystem::exists(prefix / "include" / "rejuv" / "textproto")) << "textproto is not the SDK's";

  // The CUSTOM attack hook for a service's test build (Rejuv::sdk_attack).
  EXPECT_TRUE(std::filesystem::exists(prefix / "include" / "rejuv" / "sdk" / "attack_hook.hpp"));

  // 2. Configure and build the example out of the tree, with nothing but the installed package.
  const auto configure = [&](const std::string& name, const std::filesystem::path& build,
                             std::vector<std::string> extra) {
    std::vector<std::string> args{
        "-S", (kRepo / "examples" / "hello_service").string(), "-B", build.string(), "-G", "Ninja",
        "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_PREFIX_PATH=" + prefix.string(),
        "-DCMAKE_CXX_COMPILER=" REJUV_CXX_COMPILER, "-DCMAKE_C_COMPILER=" REJUV_C_COMPILER,
        // the build's own flags (a sanitizer preset's SDK needs its runtime in the service too)
        "-DCMAKE_CXX_FLAGS=" REJUV_CXX_FLAGS, "-DCMAKE_C_FLAGS=" REJUV_C_FLAGS,
        "-DCMAKE_EXE_LINKER_FLAGS=" REJUV_EXE_LINKER_FLAGS};
    args.insert(args.end(), extra.begin(), extra.end());
    return step(name, kCmake, std::move(args));
  };
  auto configured = configure("configure", example_build, {});
  ASSERT_EQ(configured.exit_code, 0) << configured.out << configured.err;
  auto built = step("build", kCmake, {"--build", example_build.string()});
  ASSERT_EQ(built.exit_code, 0) << built.out << built.err;
  // A test build of it turns the hooks on (docs/writing_a_service.md "Injecting a fault into your own
  // service"): its CUSTOM hook compiles and links against the installed package.
  const std::filesystem::path hooks_build = dir_ / "build-hello-hooks";
  auto hooks_configured = configure("configure_hooks", hooks_build, {"-DREJUV_ATTACK_HOOKS=ON"});
  ASSERT_EQ(hooks_configured.exit_code, 0) << hooks_configured.out << hooks_configured.err;
  auto hooks_built =
      step("build_hooks", kCmake, {"--build", hooks_build.string(), "--target", "hello_monitor"});
  ASSERT_EQ(hooks_built.exit_code, 0) << hooks_built.out << hooks_built.err;
  const std::filesystem::path service = example_build / "hello_monitor";
  ASSERT_TRUE(std::filesystem::exists(service)) << built.out;

  // 3. The example's build wrote its graph with the path of the service it built, beside the policy.
  const std::filesystem::path graph = example_build / "hello.launch.pbtxt";
  ASSERT_NE(slurp(graph).find("executable: \"" + service.string() + "\""), std::string::npos) << slurp(graph);
  ASSERT_TRUE(std::filesystem::exists(example_build / "hello.policy.pbtxt"));
  // The example's own topic type (hello.idl, rejuv_add_topics): the build printed its policy entry with the
  // struct's size and alignment as compiled, and appended it to the policy the graph names.
  EXPECT_NE(slurp(example_build / "hello_topics.types.pbtxt")
                .find("types { name: \"hello::Summary\" size_bytes: 24 align_bytes: 8 }"),
            std::string::npos)
      << slurp(example_build / "hello_topics.types.pbtxt");
  EXPECT_NE(slurp(example_build / "hello.policy.pbtxt").find("types { name: \"hello::Summary\""), std::string::npos);

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

}  // namespace
