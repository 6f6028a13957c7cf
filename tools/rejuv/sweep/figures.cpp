#include "sweep/figures.hpp"

#include <fcntl.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>

#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/process.hpp"
#include "sweep/grid.hpp"
#include "sweep/params.hpp"

extern char** environ;  // NOLINT: gnuplot inherits the environment (GNUPLOT_LIB, fonts)

namespace rejuv::cli::sweep {
namespace {

namespace fs = std::filesystem;

std::optional<double> number(const std::string& text) {
  double v = 0;
  const auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || p != text.data() + text.size()) return std::nullopt;
  return v;
}

// An axis of numbers is plotted at its values; one of names (an enum) at 0, 1, 2, … with the names as tics.
bool numeric(const proto::SweepAxis& a) {
  return std::all_of(a.values().begin(), a.values().end(), [](const std::string& v) { return number(v).has_value(); });
}

double coordinate(const proto::SweepAxis& a, int i) {
  return numeric(a) ? *number(a.values(i)) : static_cast<double>(i);
}

std::string tics(const proto::SweepAxis& a) {
  if (numeric(a)) return "";
  std::string out = "(";
  for (int i = 0; i < a.values_size(); ++i) out += (i > 0 ? ", " : "") + ("\"" + a.values(i) + "\" ") + std::to_string(i);
  return out + ")";
}

std::string label(const proto::SweepAxis& a) { return axis_label(a.path(), a.unit()); }

// gnuplot string literal in single quotes ('' is a quote).
std::string gp_quoted(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

// gnuplot FILES… (found on PATH by env; no shell), its messages appended to `log`.
Result<void, std::string> run_gnuplot(const std::vector<std::string>& files, const fs::path& log) {
  const sys::UniqueFd log_fd(::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644));
  if (!log_fd) return fail("cannot write " + log.string());
  sys::SpawnSpec spec;
  spec.executable = "/usr/bin/env";
  spec.args = {"gnuplot"};
  spec.args.insert(spec.args.end(), files.begin(), files.end());
  for (char** e = environ; *e != nullptr; ++e) spec.env.emplace_back(*e);
  spec.fds = {{1, log_fd.get()}, {2, log_fd.get()}};
  auto child = sys::spawn(spec);
  if (!child) return fail("cannot start gnuplot: " + child.error().to_string());
  const auto status = child->wait();
  if (!status) return fail("waiting for gnuplot: " + status.error().to_string());
  if (status->how == sys::ExitStatus::How::Exited && status->value == 127) {
    return fail(std::string("gnuplot is not installed (apt-get install gnuplot-nox)"));
  }
  if (!status->success()) return fail("gnuplot " + status->to_string() + "; see " + log.string());
  return {};
}

}  // namespace

Result<void, std::string> write_plot_data(const fs::path& dir, const proto::SweepReport& report) {
  const proto::SweepPlan& plan = report.plan();
  std::error_code ec;
  fs::create_directories(dir / "plot", ec);
  if (ec) return fail("cannot create " + (dir / "plot").string() + ": " + ec.message());
  for (const std::string& runner : plan.runners()) {
    std::map<std::uint32_t, const proto::SweepCellResult*> cells;
    for (const proto::SweepCellResult& c : report.cells()) {
      if (c.runner() == runner) cells[c.cell()] = &c;
    }
    std::ofstream out(dir / "plot" / (runner + ".dat"));
    if (!out) return fail("cannot write " + (dir / "plot" / (runner + ".dat")).string());
    out << "# x y max_V_max max_est_err_P_max max_V_mean max_est_err_P_mean (over the seeds flown) short attacks_min"
           " (short: 1 when a seed's mission ended before the plan's attacks)\n";
    const int inner = plan.axes_size() > 1 ? plan.axes(1).values_size() : 1;
    for (std::uint32_t c = 0; c < cell_count(plan); ++c) {
      const int i0 = static_cast<int>(c) / inner, i1 = static_cast<int>(c) % inner;
      if (i1 == 0 && c > 0 && plan.axes_size() > 1) out << "\n";
      char line[256];
      const double x = coordinate(plan.axes(0), i0);
      const double y = plan.axes_size() > 1 ? coordinate(plan.axes(1), i1) : 0.0;
      const auto it = cells.find(c);
      if (it == cells.end() || it->second->ok() == 0) {
        std::snprintf(line, sizeof line, "%.12g %.12g NaN NaN NaN NaN 0 0\n", x, y);
      } else {
        const proto::SweepCellResult& r = *it->second;
        std::snprintf(line, sizeof line, "%.12g %.12g %.6g %.6g %.6g %.6g %d %u\n", x, y, r.max_v().max(),
                      r.max_est_err_p().max(), r.max_v().mean(), r.max_est_err_p().mean(),
                      r.short_of_attacks() > 0 ? 1 : 0, r.attacks_min());
      }
      out << line;
    }
  }
  return {};
}

Result<std::vector<fs::path>, std::string> draw_figures(const fs::path& dir, const proto::SweepReport& report,
                                                        const fs::path& script) {
  const proto::SweepPlan& plan = report.plan();
  if (plan.axes_size() < 1 || plan.axes_size() > 2) return fail(std::string("figures need one or two swept parameters"));
  if (auto data = write_plot_data(dir, report); !data) return fail(data.error());
  std::error_code ec;
  if (!fs::exists(script, ec)) return fail("no gnuplot script " + script.string());
  // One colour scale for both runners, reaching at least 1 (the boundary), so the panels compare.
  double zmax[2] = {1.0, 1.0};
  bool beyond[2] = {false, false};
  for (const proto::SweepCellResult& c : report.cells()) {
    if (c.ok() == 0) continue;
    zmax[0] = std::max(zmax[0], c.max_v().max());
    zmax[1] = std::max(zmax[1], c.max_est_err_p().max());
    beyond[0] = beyond[0] || c.max_v().max() >= 1.0;
    beyond[1] = beyond[1] || c.max_est_err_p().max() >= 1.0;
  }
  std::string runners;
  for (const std::string& r : plan.runners()) runners += (runners.empty() ? "" : " ") + r;
  // An axis of names (an enum) has no order between its values: no level line or boundary is interpolated across.
  const bool categorical = std::any_of(plan.axes().begin(), plan.axes().end(),
                                       [](const proto::SweepAxis& a) { return !numeric(a); });
  const auto cells_short = std::count_if(report.cells().begin(), report.cells().end(),
                                         [](const proto::SweepCellResult& c) { return c.ok() > 0 && c.short_of_attacks() > 0; });
  const auto cells_flown = std::count_if(report.cells().begin(), report.cells().end(),
                                         [](const proto::SweepCellResult& c) { return c.ok() > 0; });
  // What the cells flew: N attacks each, or fewer in some (a mission that completed first) and the title says so.
  char attacks_text[160];
  if (plan.attacks() == 0) {
    std::snprintf(attacks_text, sizeof attacks_text, "each mission flown to its end");
  } else if (cells_short == 0) {
    std::snprintf(attacks_text, sizeof attacks_text, "%u attacks per cell", plan.attacks());
  } else {
    std::snprintf(attacks_text, sizeof attacks_text, "up to %u attacks per cell (%ld of %ld cells fewer: marked *)",
                  plan.attacks(), static_cast<long>(cells_short), static_cast<long>(cells_flown));
  }
  const std::string charged = charges_text(report);
  const std::string charges = charged.empty() ? "" : "; CP/RB charged: " + charged;
  std::vector<fs::path> written;
  struct Figure {
    const char* name;
    int column;
    const char* metric;
    const char* level;
  };
  const Figure figures[] = {{"fig11a", 3, "max ||x - x_sp||^2_P (V)", "V = 1: safety boundary"},
                            {"fig11b", 4, "max ||x - x_hat||^2_P", "||x - x_hat||^2_P = 1"}};
  for (std::size_t f = 0; f < 2; ++f) {
    const Figure& fig = figures[f];
    // Two lines: what is drawn, then what each cell flew (one line would be clipped at the figure's width).
    char title[512];
    std::snprintf(title, sizeof title, "Fig. 11(%c): %s, max over %d seed%s", fig.name[5], fig.metric,
                  plan.seeds_size(), plan.seeds_size() == 1 ? "" : "s");
    const std::string subtitle = std::string(attacks_text) + charges;
    std::string vars = "dir=" + gp_quoted((dir / "plot").string()) + "; out=" + gp_quoted((dir / fig.name).string()) +
                       "; runners=" + gp_quoted(runners) + "; col=" + std::to_string(fig.column) +
                       "; dims=" + std::to_string(plan.axes_size()) + "; reached=" + (beyond[f] ? "1" : "0") + "; zmax=" + std::to_string(zmax[f] * 1.05) +
                       "; title=" + gp_quoted(title) + "; subtitle=" + gp_quoted(subtitle) +
                       "; categorical=" + (categorical ? "1" : "0") + "; attacks=" + std::to_string(plan.attacks()) +
                       "; zlabel=" + gp_quoted(fig.metric) + "; level_title=" + gp_quoted(fig.level) +
                       "; xlabel=" + gp_quoted(label(plan.axes(0))) + "; xtics_text=" + gp_quoted(tics(plan.axes(0)));
    if (plan.axes_size() > 1) {
      vars += "; ylabel=" + gp_quoted(label(plan.axes(1))) + "; ytics_text=" + gp_quoted(tics(plan.axes(1)));
    }
    // The variables go in a file next to the data (no shell quoting of paths and titles).
    const fs::path vars_file = dir / "plot" / (std::string(fig.name) + ".vars.gp");
    {
      std::ofstream v(vars_file);
      v << vars << "\n";
    }
    if (auto drawn = run_gnuplot({vars_file.string(), script.string()}, dir / "plot" / "gnuplot.log"); !drawn) {
      return fail(drawn.error());
    }
    written.push_back(dir / (std::string(fig.name) + ".png"));
    written.push_back(dir / (std::string(fig.name) + ".svg"));
  }
  return written;
}

}  // namespace rejuv::cli::sweep
