#include "figures.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string_view>
#include <system_error>

#include "figure_data.hpp"
#include "rejuv/sys/process.hpp"

extern char** environ;  // NOLINT: gnuplot gets this process's environment (fonts, locale)

#ifndef REJUV_SOURCE_DIR
#define REJUV_SOURCE_DIR ""
#endif

namespace rejuv::cli {

namespace fs = std::filesystem;

namespace {

// The first line of each CSV as RunFiles writes it (trace.csv: report.cpp's write_trace_header).
Result<void, std::string> check_header(const fs::path& file, std::string_view starts_with) {
  std::ifstream in(file);
  if (!in) return fail(file.string() + ": error: cannot read it (not a `rejuv run/sim --out` directory?)");
  std::string line;
  if (!std::getline(in, line)) return fail(file.string() + ":1:1: error: empty file, expected a CSV header");
  if (line.rfind(starts_with, 0) != 0) {
    return fail(file.string() + ":1:1: error: expected a header starting '" + std::string(starts_with) + "', got '" +
                line.substr(0, 60) + "'");
  }
  return {};
}

// A gnuplot string literal: single quotes, a quote doubled.
std::string quoted(const std::string& text) {
  std::string out = "'";
  for (char c : text) {
    if (c == '\'') out += "''";
    else if (c != '\n') out += c;
  }
  return out + "'";
}

}  // namespace

fs::path plots_dir() {
  if (const char* env = std::getenv("REJUV_PLOTS_DIR"); env != nullptr && *env != '\0') return env;
  return fs::path(REJUV_SOURCE_DIR) / "tools" / "plots";
}

Result<void, std::string> check_run_dir(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail(dir.string() + ": error: not a directory");
  if (auto ok = check_header(dir / RunFiles::kTrace, "t_s,n_m,e_m,d_m"); !ok) return ok;
  if (auto ok = check_header(dir / RunFiles::kControl, "t_s,wall_s,interval_ms,wall_interval_ms,mark,wall_mark"); !ok) return ok;
  if (auto ok = check_header(dir / RunFiles::kEvents, "t_s,wall_s,kind,epoch,generation,mode,span_ms,by"); !ok) return ok;
  return {};
}

std::optional<fs::path> find_gnuplot() {
  const char* path = std::getenv("PATH");
  std::string_view rest = path != nullptr ? path : "/usr/bin:/bin";
  while (!rest.empty()) {
    const auto colon = rest.find(':');
    const fs::path candidate = fs::path(rest.substr(0, colon)) / "gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
    rest = colon == std::string_view::npos ? std::string_view{} : rest.substr(colon + 1);
  }
  return std::nullopt;
}

FigureRun figure_run_of(const proto::RunSummary& summary) {
  return FigureRun{.runner = summary.runner(),
                   .sr = summary.sr() ? SrInRun::On : SrInRun::Off,
                   .title = summary.graph() + ", SR " + (summary.sr() ? "on" : "off") + ", attack " +
                            (summary.attack() ? "on" : "off") + ", seed " + std::to_string(summary.seed()) +
                            " (rejuv " + summary.runner() + ")"};
}

namespace {

// One figure: its script run by gnuplot, then its PNG and SVG checked. The error says what failed.
Result<std::vector<fs::path>, std::string> draw_one(const fs::path& gnuplot, const fs::path& dir, const fs::path& plots,
                                                    const FigureRun& run, const char* name) {
  const fs::path script = plots / (std::string(name) + ".gp");
  std::error_code ec;
  if (!fs::exists(script, ec)) return fail(script.string() + ": error: the figure's script is missing");
  const char* sr = nullptr;
  switch (run.sr) {
    case SrInRun::On: sr = "on"; break;
    case SrInRun::Off: sr = "off"; break;
  }
  sys::SpawnSpec spec;
  spec.executable = gnuplot.string();
  spec.args = {"-e",
               "dir=" + quoted(dir.string()) + "; runner=" + quoted(run.runner) + "; sr=" + quoted(sr) +
                   "; title=" + quoted(run.title),
               script.string()};
  for (char** e = environ; *e != nullptr; ++e) spec.env.emplace_back(*e);
  spec.fds = {{1, STDERR_FILENO}, {2, STDERR_FILENO}};
  auto child = sys::spawn(spec);
  if (!child) return fail("gnuplot: " + child.error().to_string());
  auto status = child->wait();
  if (!status) return fail("gnuplot: " + status.error().to_string());
  if (!status->success()) return fail(script.string() + ": gnuplot " + status->to_string());
  std::vector<fs::path> written;
  for (const char* ext : {".png", ".svg"}) {
    const fs::path picture = dir / (std::string(name) + ext);
    if (!fs::exists(picture, ec) || fs::file_size(picture, ec) == 0) {
      return fail(script.string() + ": gnuplot wrote no " + picture.string());
    }
    written.push_back(picture);
  }
  return written;
}

}  // namespace

Result<DrawnFigures, std::string> draw_figures(const fs::path& dir, const fs::path& plots, const FigureRun& run) {
  const auto gnuplot = find_gnuplot();
  if (!gnuplot) return fail(std::string("gnuplot not found on PATH: no figures drawn (apt-get install gnuplot-nox)"));
  DrawnFigures drawn;
  for (const char* name : kFigures) {
    auto pictures = draw_one(*gnuplot, dir, plots, run, name);
    if (!pictures) {
      drawn.failed.push_back(FigureFailure{.figure = name, .why = pictures.error()});
      continue;
    }
    drawn.written.insert(drawn.written.end(), pictures->begin(), pictures->end());
  }
  return drawn;
}

bool draw_and_report(const fs::path& dir, const FigureRun& run, const char* command) {
  const auto drawn = draw_figures(dir, plots_dir(), run);
  if (!drawn) {
    std::fprintf(stderr, "%s: %s\n", command, drawn.error().c_str());
    return !find_gnuplot().has_value();  // no gnuplot: the CSVs are the result; a failing script is a failure
  }
  if (!drawn->written.empty()) {
    std::fprintf(stderr, "%s: figures in %s:", command, dir.c_str());
    for (const fs::path& p : drawn->written) {
      if (p.extension() == ".png") std::fprintf(stderr, " %s", p.stem().c_str());
    }
    std::fprintf(stderr, " (.png and .svg)\n");
  }
  for (const FigureFailure& f : drawn->failed) {
    std::fprintf(stderr, "%s: figure %s not drawn: %s\n", command, f.figure.c_str(), f.why.c_str());
  }
  return drawn->failed.empty();
}

bool finish_out_dir(RunFiles& files, proto::RunSummary& summary, const char* command, Figures figures) {
  const auto trace_bytes = files.finish(summary);
  if (!trace_bytes) {
    std::fprintf(stderr, "%s: %s\n", command, trace_bytes.error().c_str());
    return false;
  }
  std::fprintf(stderr, "%s: wrote %s: summary.json, trace.csv (%.1f MB), control.csv, events.csv\n", command,
               files.dir().c_str(), static_cast<double>(*trace_bytes) / 1e6);
  if (figures == Figures::Skip) return true;
  return draw_and_report(files.dir(), figure_run_of(summary), command);
}

}  // namespace rejuv::cli
