#include "figure_data.hpp"

#include <system_error>

#include "report.hpp"

namespace rejuv::cli {

namespace fs = std::filesystem;

const char* mark_name(IntervalMark mark) {
  switch (mark) {
    case IntervalMark::None: return "";
    case IntervalMark::Checkpoint: return "CP";
    case IntervalMark::Rollback: return "RB";
  }
  return "";
}

void ControlIntervals::on_event(const SrEvent& event) {
  // A rollback wins: the controls the plant held through it may be compromised (§VI-B).
  const auto merge = [](IntervalMark& into, IntervalMark mark) {
    if (into != IntervalMark::Rollback) into = mark;
  };
  switch (event.kind) {
    case SrEventKind::Checkpoint:
    case SrEventKind::Rollback:
    case SrEventKind::ColdRestart: {
      const IntervalMark mark = event.kind == SrEventKind::Checkpoint ? IntervalMark::Checkpoint : IntervalMark::Rollback;
      merge(pending_, mark);
      merge(pending_sim_, mark);
      pending_after_ = event.t;
      return;
    }
    case SrEventKind::Mode:
    case SrEventKind::HandlerRun:
    case SrEventKind::TimerArmed:
    case SrEventKind::TimerRefused:
    case SrEventKind::LimitsWritten:
    case SrEventKind::CheckpointFailed:
      return;
  }
}

std::optional<ControlInterval> ControlIntervals::add(Nanos t, Nanos wall) {
  std::optional<ControlInterval> out;
  const bool sim_due = t > pending_after_;
  if (last_t_) {
    out = ControlInterval{.t = t, .wall = wall, .dt = t - *last_t_, .dwall = wall - *last_wall_,
                          .mark = sim_due ? pending_sim_ : IntervalMark::None, .wall_mark = pending_};
    max_dt_ = std::max(max_dt_, out->dt);
    ++count_;
  }
  // An event before the first update marks nothing.
  pending_ = IntervalMark::None;
  if (sim_due || !out) pending_sim_ = IntervalMark::None;
  last_t_ = t;
  last_wall_ = wall;
  return out;
}

bool TraceDecimator::keep(Nanos t, SrMode mode) {
  const bool mode_changed = mode_ != mode;
  mode_ = mode;
  if (detail_ == TraceDetail::Full) return true;
  if (!(forced_ || mode_changed || !next_ || t >= *next_)) return false;
  forced_ = false;
  if (!next_ || t >= *next_) next_ = t + period_;
  return true;
}

Result<TraceDetail, std::string> parse_trace_detail(std::string_view text) {
  if (text == "compact") return TraceDetail::Compact;
  if (text == "full") return TraceDetail::Full;
  return fail("--trace: expected compact or full, got '" + std::string(text) + "'");
}

Result<RunFiles, std::string> RunFiles::open(const fs::path& dir, TraceDetail detail) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail("--out: cannot create '" + dir.string() + "': " + ec.message());
  RunFiles files(dir, detail);
  for (auto [file, name] : {std::pair{&files.trace_, kTrace}, std::pair{&files.control_, kControl},
                            std::pair{&files.events_, kEvents}}) {
    file->reset(std::fopen((dir / name).c_str(), "w"));
    if (!*file) return fail("--out: cannot write '" + (dir / name).string() + "'");
  }
  write_trace_header(files.trace_.get());
  std::fputs("t_s,wall_s,interval_ms,wall_interval_ms,mark,wall_mark\n", files.control_.get());
  std::fputs("t_s,wall_s,kind,epoch,generation,mode,span_ms,by\n", files.events_.get());
  return files;
}

void RunFiles::trace(const flight::TraceRow& row) {
  if (trace_ && decimator_.keep(row.t, row.mode)) write_trace_row(trace_.get(), row);
}

void RunFiles::control_update(Nanos t, Nanos wall) {
  const auto interval = intervals_.add(t, wall);
  if (!interval || !control_) return;
  const double ms = static_cast<double>(interval->dt.count()) / 1e6;
  interval_ms_.add(ms);
  std::fprintf(control_.get(), "%.6f,%.6f,%.4f,%.4f,%s,%s\n", to_seconds(t).count(), to_seconds(wall).count(), ms,
               static_cast<double>(interval->dwall.count()) / 1e6, mark_name(interval->mark),
               mark_name(interval->wall_mark));
}

void RunFiles::sr_event(const SrEvent& e) {
  intervals_.on_event(e);
  decimator_.force();
  if (!events_) return;
  const char* by = "kernel";
  if (e.by && e.by->value() < names_.size()) {
    by = names_[e.by->value()].c_str();
  } else if (!e.by && names_.empty()) {
    by = "model";
  }
  std::fprintf(events_.get(), "%.6f,%.6f,%.*s,%u,%llu,%s,%.4f,%s\n", to_seconds(e.t).count(),
               to_seconds(e.wall).count(), static_cast<int>(to_string(e.kind).size()), to_string(e.kind).data(),
               e.epoch.value(), static_cast<unsigned long long>(e.g.value()), mode_name(e.mode),
               static_cast<double>(e.span.count()) / 1e6, by);
}

Result<std::uintmax_t, std::string> RunFiles::finish(proto::RunSummary& summary) {
  fill_percentiles(*summary.mutable_control_interval_ms(), interval_ms_);
  for (File* f : {&trace_, &control_, &events_}) {
    if (*f && (std::fflush(f->get()) != 0 || std::ferror(f->get()) != 0)) {
      return fail("--out: writing into '" + dir_.string() + "' failed (disk full?)");
    }
    f->reset();
  }
  File json(std::fopen((dir_ / kSummary).c_str(), "w"));
  if (!json || std::fputs((to_json(summary) + "\n").c_str(), json.get()) < 0 || std::fflush(json.get()) != 0) {
    return fail("--out: cannot write '" + (dir_ / kSummary).string() + "'");
  }
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(dir_ / kTrace, ec);
  return ec ? 0 : size;
}

}  // namespace rejuv::cli
