// The subcommands of `rejuv` (docs/design.md §10). Each takes its arguments after the command name and returns
// the process exit code (cli::Exit).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <span>
#include <string_view>

namespace rejuv::cli {

int run_audit(std::span<const std::string_view> args);  // cmd_audit.cpp
int run_sim(std::span<const std::string_view> args);    // cmd_sim.cpp
int run_run(std::span<const std::string_view> args);    // cmd_run.cpp
int run_gcs(std::span<const std::string_view> args);    // cmd_gcs.cpp
int run_bench(std::span<const std::string_view> args);  // cmd_bench.cpp
// bench_realtime.cpp: `rejuv bench realtime` (GRAPH "" = the square; files in `out`, default a temporary folder).
int run_bench_realtime(const std::string& graph, std::uint64_t seconds, std::uint64_t rounds,
                       const std::optional<std::filesystem::path>& out);
// bench_across_hosts.cpp: `rejuv bench across-hosts`; the link rows fly two kernels (`rejuv run --host`) unless
// Skip.
enum class LinkRow : std::uint8_t { Measure, Skip };
struct AcrossHostsBench {
  std::uint64_t samples = 2500;       // per Cyclone row and round; the link row flies max(5, samples / 250) s
  std::uint64_t rounds = 1;           // of the Cyclone rows, alternated
  std::uint64_t reopen_seconds = 10;  // the flight with SR whose CP → MC are measured
  std::optional<std::filesystem::path> out;  // the files; default a temporary folder
  LinkRow link = LinkRow::Measure;
};
int run_bench_across_hosts(const AcrossHostsBench& bench);
int run_report(std::span<const std::string_view> args);  // cmd_report.cpp
int run_faults(std::span<const std::string_view> args);  // cmd_faults.cpp
int run_soak(std::span<const std::string_view> args);    // cmd_soak.cpp
int run_sweep(std::span<const std::string_view> args);   // cmd_sweep.cpp
int run_new(std::span<const std::string_view> args);     // cmd_new.cpp
int run_keys(std::span<const std::string_view> args);    // cmd_keys.cpp
int run_ros2(std::span<const std::string_view> args);    // cmd_ros2.cpp

}  // namespace rejuv::cli
