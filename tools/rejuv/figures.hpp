// Draws the figures of a run directory (figure_data.hpp: trace.csv, control.csv, events.csv, summary.json)
// with gnuplot, one script per figure under tools/plots/, each as PNG (pngcairo) and SVG:
//   fig7_control_intervals  every interval between control updates against time, CP and RB marked (§VI-B)
//   fig8_sr_timeline        the SR timeline: modes, handler requests, timer arms and refusals, CP, RB (§V-C)
//   fig9_3d                 the trajectory in 3-D: true, estimate, setpoints (§VI-C)
//   fig10_xy_time           north and east against time: true, estimate, setpoint (§VI-C)
//   safety                  V = ‖x − x_sp‖²_P and the estimation error ‖x − x̂‖²_P against time
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "figure_data.hpp"

namespace rejuv::cli {

// The help of `--out` and `--trace` (rejuv run and rejuv sim).
inline constexpr const char* kOutHelp =
    "write DIR/summary.json, trace.csv, control.csv (every interval between control updates, CP/RB marked),\n"
    "events.csv (the SR events) and, with gnuplot, Figs. 7-10 and V/estimation error as PNG and SVG";
inline constexpr const char* kNoFiguresHelp = "with --out: the CSVs and the summary only, no pictures (sweeps)";
inline constexpr const char* kTraceHelp =
    "the trace in --out: compact (a row every 20 ms and at every mode change or SR event) or full\n"
    "(every 4 ms control period)";

// The figures, in the order they are drawn: the base names of the scripts and of the pictures.
inline constexpr const char* kFigures[] = {"fig7_control_intervals", "fig8_sr_timeline", "fig9_3d",
                                           "fig10_xy_time", "safety"};

// Checks that `dir` holds the files of an `--out` run (each present, with the header this version writes).
// The error names the file and what is wrong with it.
[[nodiscard]] Result<void, std::string> check_run_dir(const std::filesystem::path& dir);

// The gnuplot executable on PATH, if any.
[[nodiscard]] std::optional<std::filesystem::path> find_gnuplot();

// What a figure says of the run it draws: the command that flew it ("run" or "sim": the model has no real-time
// intervals to draw), whether SR ran (without it a panel of CP/RB marks or SR events says "no SR in this run"),
// and the title that heads every figure.
enum class SrInRun : std::uint8_t { On, Off };
struct FigureRun {
  std::string runner;
  SrInRun sr = SrInRun::On;
  std::string title;
};
[[nodiscard]] FigureRun figure_run_of(const proto::RunSummary& summary);

// One figure gnuplot did not draw, by name (a kFigures entry), and why.
struct FigureFailure {
  std::string figure;
  std::string why;
};
// The pictures written and the figures that failed: each figure is drawn on its own, so one that fails never
// stops the others.
struct DrawnFigures {
  std::vector<std::filesystem::path> written;
  std::vector<FigureFailure> failed;
};

// Draws every figure of `dir` with gnuplot (scripts from `plots_dir`). The error is for what stops them all
// (gnuplot missing); a figure that fails is in `failed`. The CSVs stay either way.
[[nodiscard]] Result<DrawnFigures, std::string> draw_figures(const std::filesystem::path& dir,
                                                             const std::filesystem::path& plots_dir,
                                                             const FigureRun& run);

// Draws the figures after a run and says on stderr what was written and which failed (or why none was drawn).
// Returns false if gnuplot was there and a figure failed.
bool draw_and_report(const std::filesystem::path& dir, const FigureRun& run, const char* command);

// The end of an `--out` run: finishes `files` (summary.json with the control intervals), says how large the
// trace is, and draws the figures (unless `figures` is Skip: `--no-figures`, e.g. in a sweep). False when a
// file could not be written or gnuplot failed (exit 1).
enum class Figures : std::uint8_t { Draw, Skip };
bool finish_out_dir(RunFiles& files, proto::RunSummary& summary, const char* command, Figures figures);

// tools/plots of the source tree (REJUV_PLOTS_DIR overrides it).
[[nodiscard]] std::filesystem::path plots_dir();

}  // namespace rejuv::cli
