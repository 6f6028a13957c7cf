// `rejuv bench across-hosts` as a user runs it (docs/across_hosts.md "The baseline"): root only (network
// namespaces; skipped otherwise). A short run: both Cyclone rows (raw, and DDS Security from the keystore
// `rejuv keys` made) deliver every sample they published between the two namespaces; the link's row (two
// `rejuv run --host` kernels, the probe's topic through both link processes) delivers samples too; the samples
// are in DIR/latency.csv; the reopening (the same hosts flown with SR) finds a sample in at least one MC window
// after the links met (DIR/reopen.csv); and no namespace of the run is left behind. The reopening flies 30 s
// (≈ 40 MC windows): the links meet through the vehicle's 0.2 s MC windows only, and Cyclone resends a lost
// handshake message once a second, so meeting can take many windows (docs/performance.md). No timing is asserted: the
// latencies and the reopening's times are the benchmark's output, not a pass/fail criterion.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "../rejuv_cli.hpp"

namespace {

using rejuv::test_support::slurp;
namespace fs = std::filesystem;

TEST(AcrossHostsBench, RawAndSecureRows_EverySampleDelivered_LinkRowsDeliver) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root: it makes network namespaces and a veth pair (ip netns)";
  const fs::path dir = fs::temp_directory_path() / ("rejuv_bench_across_hosts_" + std::to_string(::getpid()));
  fs::create_directories(dir / "log");
  const auto r = rejuv::test_support::run_rejuv(
      dir / "log", {"bench", "across-hosts", "--samples", "200", "--rounds", "1", "--reopen-seconds", "30", "--out",
                    (dir / "out").string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  // "  raw      Cyclone DDS, no security   p50 p99 max ratios 200/200", the same for secure.
  for (const char* row : {"\n  raw ", "\n  secure "}) {
    const auto at = r.out.find(row);
    ASSERT_NE(at, std::string::npos) << row << "\n" << r.out;
    const std::string line = r.out.substr(at + 1, r.out.find('\n', at + 1) - at - 1);
    EXPECT_NE(line.find(" 200/200"), std::string::npos) << line;
  }
  const auto link = r.out.find("\n  link ");
  ASSERT_NE(link, std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("failed", link), std::string::npos) << r.out;
  const std::string csv = slurp(dir / "out" / "latency.csv");
  EXPECT_EQ(rejuv::test_support::count_of(csv, "\nraw,"), 200U);
  EXPECT_EQ(rejuv::test_support::count_of(csv, "\nsecure,"), 200U);
  EXPECT_GT(rejuv::test_support::count_of(csv, "\nlink,"), 200U);  // 5 s of flight at 250 Hz, less its first second
  // The reopening: printed beside the rows, and at least one MC window after the links met (discovery = 0) with a
  // sample (opened_s,closed_s,first_ms,first_new_ms,first_published_before,discovery).
  const auto reopen = r.out.find("\n  reopen ");
  ASSERT_NE(reopen, std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("failed", reopen), std::string::npos) << r.out;
  std::istringstream windows(slurp(dir / "out" / "reopen.csv"));
  std::size_t with_sample = 0;
  for (std::string line; std::getline(windows, line);) {
    std::vector<std::string> f;
    std::istringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() == 6 && f[5] == "0" && !f[2].empty()) ++with_sample;
  }
  EXPECT_GE(with_sample, 1U) << slurp(dir / "out" / "reopen.csv");
  // The run's namespaces (rjP_v<pid>, rjP_c<pid> of the bench's process) are gone.
  fs::create_directories(dir / "ip");
  const auto ns = rejuv::test_support::run_program(dir / "ip", "/usr/sbin/ip", {"netns", "list"});
  EXPECT_EQ(ns.out.find("rjP_"), std::string::npos) << ns.out;
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
