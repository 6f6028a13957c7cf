// Flying the tasks of `rejuv sweep` (docs/sweep.md). The model (`sim`) runs in this process, `--jobs` threads;
// the runtime (`run`) as `rejuv run` children (run_child.hpp), up to `--jobs` at a time, each on its own CPU
// (--cpu K), its own DDS domain (a lease of rejuv/sys/lease.hpp, shared with the tests and any other
// sweep, held while its mission flies) and an ephemeral network port (--net-port 0). Each finished task's
// record is written at once (grid.hpp), so an interrupted sweep loses only the missions in flight.
// SIGINT/SIGTERM: the missions in flight are stopped cleanly (SIGTERM to each child, which shuts its kernel
// and services down) and reaped; their records are not written.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/event.hpp"
#include "sweep.pb.h"
#include "sweep/grid.hpp"

namespace rejuv::cli::sweep {

// A cell's launch, written to DIR/launch/cell-NNNN.launch.pbtxt, and the loader's verdict on it.
struct CellLaunch {
  std::filesystem::path file;
  std::string text;
  std::string refused;  // non-empty: the launch loader (or the control design) refused it; the message
};

struct ExecConfig {
  std::filesystem::path dir;
  unsigned jobs = 1;
  bool tty = false;                        // a progress bar (else one line per finished task)
  const sys::SignalFd* signals = nullptr;  // SIGINT, SIGTERM
};

enum class ExecOutcome : std::uint8_t { Done, Interrupted };

// Flies `todo` (of `plan`, whose cells are `cells`); `kept` tasks are already done (for the progress count).
[[nodiscard]] Result<ExecOutcome, std::string> execute(const proto::SweepPlan& plan,
                                                       const std::vector<CellLaunch>& cells,
                                                       const std::vector<Task>& todo, std::size_t kept,
                                                       const ExecConfig& config);

}  // namespace rejuv::cli::sweep
