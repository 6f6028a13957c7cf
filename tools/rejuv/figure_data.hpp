// The data of the figures of a run (paper §VI-B/C, Figs. 7–10), as `rejuv run --out DIR` and `rejuv sim
// --out DIR` write it: the interval between consecutive control updates with the checkpoints and rollbacks
// that fell inside (Fig. 7, control.csv), the SR events (Fig. 8, events.csv), the trace (Figs. 9, 10, V and the
// estimation error; trace.csv, compact by default) and the summary (summary.json). tools/plots/fig*.gp draw
// them (figures.hpp); `rejuv report figures DIR` draws them again from these files.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/core/sr_event.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

// What a checkpoint or rollback left on a control interval (Fig. 7's marks).
enum class IntervalMark : std::uint8_t { None, Checkpoint, Rollback };
[[nodiscard]] const char* mark_name(IntervalMark mark);  // "", "CP", "RB"

// One interval of Fig. 7: from the previous control update to this one.
struct ControlInterval {
  Nanos t{0};      // this update [simulated]
  Nanos wall{0};   // this update [real, monotonic]
  Nanos dt{0};     // since the previous update [simulated]
  Nanos dwall{0};  // since the previous update [real]
  // The checkpoint or rollback that lengthened this interval (a rollback wins over a checkpoint): in
  // simulated time (`mark`) and in real time (`wall_mark`).
  IntervalMark mark = IntervalMark::None;
  IntervalMark wall_mark = IntervalMark::None;
};

// Fig. 7 from a sequence of control updates and SR events in the order they happened: each update after the
// first gives the interval since the previous one, marked with the checkpoint or rollback that lengthened it.
// In real time that is the interval in which the operation happened. In simulated time it is the first
// interval that ends after the operation's time: in lockstep the kernel's clock stands still during a
// checkpoint or rollback, the step's own update follows it at the same time, and the real duration is charged
// to the plant's next step (docs/design.md §6), so the gap shows one interval later; in realtime and in the model the
// two rules pick the same interval.
class ControlIntervals {
 public:
  void on_event(const SrEvent& event);
  // The interval this update closes; nullopt for the first update.
  [[nodiscard]] std::optional<ControlInterval> add(Nanos t, Nanos wall);
  [[nodiscard]] Nanos max_dt() const { return max_dt_; }
  [[nodiscard]] std::uint64_t count() const { return count_; }

 private:
  std::optional<Nanos> last_t_, last_wall_;
  IntervalMark pending_ = IntervalMark::None;       // for the next interval in real time
  IntervalMark pending_sim_ = IntervalMark::None;   // for the first interval ending after pending_after_
  Nanos pending_after_{0};
  Nanos max_dt_{0};
  std::uint64_t count_ = 0;
};

// How much of the trace a run writes: every row (each 4 ms control period), or one row per `period` plus
// every row at which the mode changed or an SR event happened (the default of `--out`).
enum class TraceDetail : std::uint8_t { Compact, Full };
inline constexpr Nanos kCompactTracePeriod{std::chrono::milliseconds{20}};

class TraceDecimator {
 public:
  explicit TraceDecimator(TraceDetail detail, Nanos period = kCompactTracePeriod) : detail_(detail), period_(period) {}
  // The next row is kept whatever its time (an SR event happened).
  void force() { forced_ = true; }
  // Whether the row at `t` in `mode` goes into the trace.
  [[nodiscard]] bool keep(Nanos t, SrMode mode);

 private:
  TraceDetail detail_;
  Nanos period_;
  std::optional<Nanos> next_{};
  std::optional<SrMode> mode_{};
  bool forced_ = false;
};

// The files of an `--out DIR` run. Created by open(); each record call writes its row (buffered stdio, no
// allocation per row); finish() writes the summary and closes everything.
class RunFiles {
 public:
  static constexpr const char* kTrace = "trace.csv";
  static constexpr const char* kControl = "control.csv";
  static constexpr const char* kEvents = "events.csv";
  static constexpr const char* kSummary = "summary.json";

  // Creates DIR (and parents) and the CSVs with their headers. The error is a message for the user.
  [[nodiscard]] static Result<RunFiles, std::string> open(const std::filesystem::path& dir, TraceDetail detail);

  // Who asked for an SR event, by ServiceId (the runtime's service names); the model's events have none.
  void set_service_names(std::vector<std::string> names) { names_ = std::move(names); }

  void trace(const flight::TraceRow& row);
  void control_update(Nanos t, Nanos wall);
  void sr_event(const SrEvent& event);
  // Fills the summary's control_interval_ms, writes summary.json, closes the files. Returns the trace's size.
  [[nodiscard]] Result<std::uintmax_t, std::string> finish(proto::RunSummary& summary);

  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }

 private:
  struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  using File = std::unique_ptr<std::FILE, FileCloser>;
  RunFiles(std::filesystem::path dir, TraceDetail detail) : dir_(std::move(dir)), decimator_(detail) {}

  std::filesystem::path dir_;
  File trace_, control_, events_;
  TraceDecimator decimator_;
  ControlIntervals intervals_;
  kernel::DurationSamples interval_ms_;  // the summary's percentiles (bounded, no allocation per update)
  std::vector<std::string> names_;
};

// Parses `--trace compact|full`.
[[nodiscard]] Result<TraceDetail, std::string> parse_trace_detail(std::string_view text);

}  // namespace rejuv::cli
