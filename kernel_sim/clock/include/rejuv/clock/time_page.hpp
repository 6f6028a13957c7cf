// The kernel's time page (docs/design.md §6): services never read an OS clock; now(), the SR mode and the rollback
// epoch come from one page that only the kernel writes (a memfd mapped read-write by the kernel and handed
// to every service read-only at fd 4, wire::kTimePageFd). The page is not part of any service image, so
// time stays monotonic across a rollback. Layout: wire::TimePage (a seqlock).
//
// No service can write it or stall its readers (a writable reopen of fd 4 through /proc/self/fd/4 that made
// the sequence odd would otherwise hang every reader, restored images included): the memfd is sealed against
// every write but the kernel's own mapping
// (F_SEAL_FUTURE_WRITE, mode 0444: sys::seal_against_writes); the writer keeps its own sequence and never
// reads it back from the page, so whatever the page holds, the next write makes it consistent again; and a
// reader gives up after a bounded number of tries, counts it and keeps its last consistent sample.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "rejuv/channel/wire.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/memory.hpp"

namespace rejuv::clock {

// Bytes of the page: one VM page.
inline constexpr std::size_t kTimePageBytes = 4096;
static_assert(sizeof(wire::TimePage) <= kTimePageBytes);

// One consistent reading of the page.
struct TimeSample {
  Nanos now{0};
  SrMode mode = SrMode::SC;
  Epoch epoch{};
};

// The kernel's side: owns the memfd and its read-write mapping.
class TimePageWriter {
 public:
  [[nodiscard]] static sys::SysResult<TimePageWriter> create();

  // Publishes a new reading (seqlock write: readers never see a torn one).
  void write(const TimeSample& sample);
  void set_now(Nanos now);
  [[nodiscard]] TimeSample current() const { return current_; }
  // The read-only fd every service gets at fd 4 (one open file description, O_RDONLY).
  [[nodiscard]] const sys::UniqueFd& read_only_fd() const { return read_only_; }

 private:
  TimePageWriter(sys::UniqueFd memfd, sys::UniqueFd read_only, sys::Mapping mapping)
      : memfd_(std::move(memfd)), read_only_(std::move(read_only)), mapping_(std::move(mapping)) {}
  [[nodiscard]] wire::TimePage& page() const;
  sys::UniqueFd memfd_;
  sys::UniqueFd read_only_;
  sys::Mapping mapping_;
  TimeSample current_{};
  std::uint64_t sequence_ = 0;  // the writer's own (even) sequence: never read back from the shared page
};

// How many times a reader tries for a consistent sample before it gives up: the first kSpinTries spin, the
// rest yield the CPU between tries (a writer preempted between its two sequence stores gets to finish). The
// kernel's write is four stores: a reader that sees no even, unchanged sequence in this many tries is not
// racing a writer, the page is broken.
inline constexpr int kTimePageSpinTries = 1000;
inline constexpr int kTimePageTries = 20000;

// A service's side: maps the page read-only and reads consistent samples.
class TimePageReader {
 public:
  TimePageReader() = default;
  // Maps fd (normally wire::kTimePageFd) read-only. The fd may be closed afterwards.
  [[nodiscard]] static sys::SysResult<TimePageReader> map(int fd);
  // A consistent sample, or nullopt after kTimePageTries tries (never spins forever).
  [[nodiscard]] std::optional<TimeSample> try_read() const;
  // try_read(), or — when it gives up — the last consistent sample this reader saw, and the give-up counted
  // (stalls()).
  [[nodiscard]] TimeSample read() const;
  [[nodiscard]] std::uint64_t stalls() const { return stalls_; }
  [[nodiscard]] bool valid() const { return mapping_.valid(); }

 private:
  explicit TimePageReader(sys::Mapping mapping) : mapping_(std::move(mapping)) {}
  sys::Mapping mapping_;
  mutable TimeSample last_{};
  mutable std::uint64_t stalls_ = 0;
};

}  // namespace rejuv::clock
