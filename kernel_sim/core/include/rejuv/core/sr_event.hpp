// What the SR machinery did, one event at a time (paper §VI-B, Figs. 7 and 8): the same record from the
// runtime's kernel (kernel::Observer::on_sr_event) and from the model (flight::SimObservers::sr_event), so
// that `rejuv run --out` and `rejuv sim --out` write one events CSV and draw the same figures.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv {

enum class SrEventKind : std::uint8_t {
  Mode,              // the mode became `mode` (a handler's request; RB at a rollback; SC at a cold restart)
  HandlerRun,        // the rollback handler (Fig. 6) starts a run of epoch `epoch` (model only: the runtime's
                     // handler is a service; its runs show as its SC request after each rollback)
  TimerArmed,        // the rejuvenation timer armed for `span` (do_timer, §V-A): once per epoch
  TimerRefused,      // a second arm in the same epoch, refused (docs/design.md §7: the recursive do_timer of §V-C)
  LimitsWritten,     // the restricted limits Ū written before MC (§IV-C)
  Checkpoint,        // generation `g` committed; `span` = how long the software was stopped [real time]
  CheckpointFailed,  // generation `g` abandoned
  Rollback,          // the software restored to generation `g`, new epoch `epoch`; `span` as for Checkpoint
  ColdRestart,       // no usable generation: the graph restarted from its binaries, in SC
};
inline constexpr std::size_t kSrEventKinds = 9;
[[nodiscard]] constexpr std::string_view to_string(SrEventKind kind) {
  switch (kind) {
    case SrEventKind::Mode: return "mode";
    case SrEventKind::HandlerRun: return "handler_run";
    case SrEventKind::TimerArmed: return "timer_armed";
    case SrEventKind::TimerRefused: return "timer_refused";
    case SrEventKind::LimitsWritten: return "limits_written";
    case SrEventKind::Checkpoint: return "checkpoint";
    case SrEventKind::CheckpointFailed: return "checkpoint_failed";
    case SrEventKind::Rollback: return "rollback";
    case SrEventKind::ColdRestart: return "cold_restart";
  }
  return "unknown";
}

struct SrEvent {
  SrEventKind kind = SrEventKind::Mode;
  Nanos t{0};                  // simulated (kernel) time at which it happened
  Nanos wall{0};               // real time (monotonic) at which it happened
  Epoch epoch{};               // the epoch it happened in (Rollback: the new one)
  Generation g{};              // Checkpoint, CheckpointFailed, Rollback
  SrMode mode = SrMode::MC;    // the mode after it
  Nanos span{0};               // TimerArmed: the delay; Checkpoint, Rollback: the real duration
  std::optional<ServiceId> by{};  // the service that asked (nullopt: the kernel itself)
};

}  // namespace rejuv
