// The figures of `rejuv sweep` (§VI-D Fig. 11): per metric one picture, model (sim) and runtime (run) side by
// side; with two swept parameters a map of the cells with the level-1 contour (the V = 1 boundary of the
// safety set) drawn, with one a line plot. gnuplot (tools/plots/sweep.gp) draws them as PNG and SVG.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "sweep.pb.h"

namespace rejuv::cli::sweep {

// The data gnuplot reads: DIR/plot/<runner>.dat, one line per cell (axis 0, axis 1, max V max, max est. err
// max, max V mean, max est. err mean; NaN where a cell has no flown seed), a blank line between rows of axis 0.
[[nodiscard]] Result<void, std::string> write_plot_data(const std::filesystem::path& dir,
                                                        const proto::SweepReport& report);

// Draws DIR/fig11a.{png,svg} (max ‖x − x_sp‖²_P) and DIR/fig11b.{png,svg} (max ‖x − x̂‖²_P). Returns the files
// written; an error when gnuplot is missing or fails.
[[nodiscard]] Result<std::vector<std::filesystem::path>, std::string> draw_figures(
    const std::filesystem::path& dir, const proto::SweepReport& report, const std::filesystem::path& script);

}  // namespace rejuv::cli::sweep
