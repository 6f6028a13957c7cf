// `rejuv run` flown as a child process of another command (`rejuv report table`, `rejuv sweep --runner run`),
// so that each runtime mission is exactly what a user gets from `rejuv run` (its checks, summary and exit code).
// The child is this very executable; its stdout and stderr go to a log file; it has its own process group
// (Ctrl-C reaches the parent only, which stops it cleanly) and dies with the parent (PR_SET_PDEATHSIG, in
// sys::spawn), and the ChildProcess handle kills and reaps it when dropped: none is ever left behind.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/process.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

// Starts `rejuv run ARGS…` with its output appended to `log` (created or truncated).
[[nodiscard]] Result<sys::ChildProcess, std::string> start_rejuv_run(const std::vector<std::string>& args,
                                                                     const std::filesystem::path& log);

// The RunSummary `rejuv run --summary-json` wrote, if it is there and parses.
[[nodiscard]] std::optional<proto::RunSummary> read_summary(const std::filesystem::path& path);
// The last progress line `rejuv run` wrote to its log ("t = … mode … max V …"), or "".
[[nodiscard]] std::string last_progress(const std::filesystem::path& log);
// The last `lines` lines of a log (for an error message).
[[nodiscard]] std::string log_tail(const std::filesystem::path& log, std::size_t lines);

}  // namespace rejuv::cli
