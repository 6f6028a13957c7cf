// `rejuv run` of a graph whose service fails at boot: the real binary, the real
// flight graph (launch/quad_square_paper) with one thing wrong. Before the graph has booted there is no image to
// roll back to, so the run stops — SR on or off — with exit 1 and the service's own error, instead of
// waiting for ever. The test finishing at all is part of what it checks (ctest TIMEOUT); no timing is asserted.
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"

namespace {

using rejuv::test_support::kRepo;
using rejuv::test_support::slurp;
using Outcome = rejuv::test_support::CliOutcome;

class BootFailure : public rejuv::test_support::ScratchDirTest {
 protected:
  BootFailure() : ScratchDirTest("rejuv_boot_failure_") {}

  // The shipped square graph, its policy path made absolute, then `edit`ed.
  std::filesystem::path graph(const std::function<std::string(std::string)>& edit) const {
    std::string text = slurp(kRepo / "launch" / "quad_square_paper.launch.pbtxt");
    const std::string rel = "policy: \"../policies/quad_sr.policy.pbtxt\"";
    text.replace(text.find(rel), rel.size(), "policy: \"" + (kRepo / "policies" / "quad_sr.policy.pbtxt").string() + "\"");
    const auto p = dir_ / "g.launch.pbtxt";
    std::ofstream(p) << edit(text);
    return p;
  }

  // `rejuv run GRAPH <extra>` on this process's own DDS domain, output captured.
  Outcome run(const std::filesystem::path& graph, const std::vector<std::string>& extra) const {
    std::vector<std::string> args{"run", graph.string(), "--domain", std::to_string(rejuv::test_support::kOwnDdsDomain)};
    args.insert(args.end(), extra.begin(), extra.end());
    return rejuv::test_support::run_rejuv(dir_, std::move(args));
  }
};

// ext_link refuses a home latitude without its longitude (a rule between two params that its declarations,
// each in range, cannot state) and exits 1 before it is Ready.
std::string refused_parameter(std::string text) {
  text = std::regex_replace(text, std::regex("  params \\{ name: \"home_(lat|lon)_deg\"[^\n]*\n"), "");  // the graph's home
  const std::string exe = "executable: \"rejuv_ext_link\"\n";
  return text.insert(text.find(exe) + exe.size(), "  params { name: \"home_lat_deg\" number: 45 }\n");
}

// `line` after ext_link's executable line of the shipped graph, and that line's number (1-based).
std::pair<std::string, int> with_ext_link_line(std::string text, const std::string& line) {
  const std::string exe = "executable: \"rejuv_ext_link\"\n";
  const std::size_t at = text.find(exe) + exe.size();
  text.insert(at, line);
  return {text, static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n')) + 1};
}

// Every service is /bin/true: it exits 0 without ever saying Hello.
std::string all_bin_true(std::string text) {
  return std::regex_replace(text, std::regex("executable: \"rejuv_(?!plant)[a-z0-9_]+\""), "executable: \"/bin/true\"");
}

TEST_F(BootFailure, RefusedParameterWithSr_Exit1WithTheServicesError) {
  const Outcome r = run(graph(refused_parameter), {});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("service 'ext_link'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("failed at boot"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("expected both coordinates"), std::string::npos) << r.err;
}

TEST_F(BootFailure, RefusedParameterWithoutSr_Exit1WithTheServicesError) {
  const Outcome r = run(graph(refused_parameter), {"--no-sr"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("service 'ext_link'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("expected both coordinates"), std::string::npos) << r.err;
}

// A value outside ext_link's declared range (rejuv_ext_link.params.pbtxt) never reaches the service: the kernel
// refuses the graph at the param's line and column before anything starts, exit 2.
TEST_F(BootFailure, ParameterOutOfDeclaredRange_Exit2AtItsLineBeforeAnythingStarts) {
  int line = 0;
  const auto g = graph([&](std::string text) {
    auto [edited, at] = with_ext_link_line(std::move(text), "  params { name: \"telemetry_period_s\" number: -1 }\n");
    line = at;
    return edited;
  });
  const Outcome r = run(g, {});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(g.string() + ":" + std::to_string(line) + ":39: error: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("-1 s is out of range: expected [0.01, 10] s"), std::string::npos) << r.err;
  EXPECT_EQ((r.out + r.err).find("services ready"), std::string::npos) << "no service may have started: " << r.err;
}

// The trap of a misspelt name (the service would fly its default): refused at the name, with the declared one.
TEST_F(BootFailure, MisspeltParameter_Exit2AtItsLineWithSuggestion) {
  int line = 0;
  const auto g = graph([&](std::string text) {
    auto [edited, at] = with_ext_link_line(std::move(text), "  params { name: \"telemetry_perod_s\" number: 0.5 }\n");
    line = at;
    return edited;
  });
  const Outcome r = run(g, {"--no-sr"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(g.string() + ":" + std::to_string(line) + ":12: error: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(did you mean \"telemetry_period_s\"?)"), std::string::npos) << r.err;
}

TEST_F(BootFailure, BinTrueWithSr_Exit1NamingTheServiceAndItsExit) {
  const Outcome r = run(graph(all_bin_true), {});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("(/bin/true) failed at boot: "), std::string::npos) << r.err;
}

TEST_F(BootFailure, BinTrueWithoutSr_Exit1NamingTheServiceAndItsExit) {
  const Outcome r = run(graph(all_bin_true), {"--no-sr"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("(/bin/true) failed at boot: "), std::string::npos) << r.err;
}

// tests/test_domain.hpp: this process's domain is one byte of one fixed lock file, held for its whole life
// (another open file description cannot take it), so no per-domain file is left behind in /tmp.
// keep_generations 16 needs more fds than a hard limit of 256 allows: refused before anything starts, with
// what to change, instead of failing spawns or checkpoints in flight.
TEST_F(BootFailure, TooFewFdsForKeepGenerations_Exit1NamingTheLimit) {
  const auto g = graph([](std::string text) {
    const std::string k = "keep_generations: 2";
    return text.replace(text.find(k), k.size(), "keep_generations: 16");
  });
  // `rejuv run` in a child whose hard fd limit is 256 (this process keeps its own).
  const std::string out = (dir_ / "stdout").string(), err = (dir_ / "stderr").string();
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const rlimit low{256, 256};
    const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (::setrlimit(RLIMIT_NOFILE, &low) != 0 || o < 0 || e < 0 || ::dup2(o, 1) < 0 || ::dup2(e, 2) < 0) ::_exit(99);
    const std::string exe = rejuv::test_support::kRejuv.string(), domain = std::to_string(rejuv::test_support::kOwnDdsDomain);
    ::execl(exe.c_str(), exe.c_str(), "run", g.c_str(), "--domain", domain.c_str(), "--duration", "5", nullptr);
    ::_exit(98);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  const Outcome r{.exit_code = WEXITSTATUS(status), .out = slurp(out), .err = slurp(err)};
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("keep_generations 16"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("ulimit -n"), std::string::npos) << r.err;
  EXPECT_EQ((r.out + r.err).find("services ready"), std::string::npos) << "no service may have started: " << r.err;
}

TEST(TestDomain, OwnDomainIsAByteOfTheOneLockFile_HeldByThisProcess) {
  ASSERT_TRUE(std::filesystem::exists(rejuv::test_support::kDomainLockFile));
  const int fd = ::open(rejuv::test_support::kDomainLockFile, O_RDWR | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  struct flock range{};
  range.l_type = F_WRLCK;
  range.l_whence = SEEK_SET;
  range.l_start = static_cast<off_t>(rejuv::test_support::kOwnDdsDomain);
  range.l_len = 1;
  EXPECT_NE(::fcntl(fd, F_OFD_SETLK, &range), 0) << "domain " << rejuv::test_support::kOwnDdsDomain << " is not held";
  ::close(fd);
}

}  // namespace
