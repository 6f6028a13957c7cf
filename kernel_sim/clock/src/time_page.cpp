#include "rejuv/clock/time_page.hpp"

#include <sched.h>

#include <atomic>
#include <new>

namespace rejuv::clock {

sys::SysResult<TimePageWriter> TimePageWriter::create() {
  auto memfd = sys::make_memfd("rejuv-time-page", kTimePageBytes);
  if (!memfd) return std::unexpected(memfd.error());
  auto mapping = sys::Mapping::map(*memfd, kTimePageBytes, sys::Access::ReadWrite);
  if (!mapping) return std::unexpected(mapping.error());
  // The kernel's mapping is made: from here on no fd of the page can write it (the magic link included).
  if (auto sealed = sys::seal_against_writes(*memfd); !sealed) return std::unexpected(sealed.error());
  auto read_only = sys::reopen_read_only(*memfd);
  if (!read_only) return std::unexpected(read_only.error());
  // The page is zero-filled by the memfd; placement-new gives the atomics their lifetime.
  new (mapping->data()) wire::TimePage{};
  TimePageWriter writer(std::move(*memfd), std::move(*read_only), std::move(*mapping));
  writer.write(TimeSample{});
  return writer;
}

wire::TimePage& TimePageWriter::page() const { return *static_cast<wire::TimePage*>(mapping_.data()); }

// A sequence lock without fences (ThreadSanitizer does not model fences): each field is stored with release
// and loaded with acquire, so a reader that sees any field of a write in progress also sees its odd sequence
// when it loads the sequence again. On x86 these are the same plain moves as relaxed ones.
// The sequence is the writer's own (sequence_), never loaded from the page: a page made odd behind its back
// is even again after this write.
void TimePageWriter::write(const TimeSample& sample) {
  wire::TimePage& p = page();
  const std::uint64_t seq = sequence_;
  sequence_ = seq + 2;
  p.sequence.store(seq + 1, std::memory_order_relaxed);  // odd: writing
  p.now_ns.store(static_cast<std::uint64_t>(sample.now.count()), std::memory_order_release);
  p.mode.store(static_cast<std::uint32_t>(sample.mode), std::memory_order_release);
  p.epoch.store(sample.epoch.value(), std::memory_order_release);
  p.sequence.store(seq + 2, std::memory_order_release);  // even: stable
  current_ = sample;
}

void TimePageWriter::set_now(Nanos now) {
  TimeSample s = current_;
  s.now = now;
  write(s);
}

sys::SysResult<TimePageReader> TimePageReader::map(int fd) {
  auto mapping = sys::Mapping::map_fd(fd, kTimePageBytes, sys::Access::ReadOnly);
  if (!mapping) return std::unexpected(mapping.error());
  return TimePageReader(std::move(*mapping));
}

std::optional<TimeSample> TimePageReader::try_read() const {
  const auto* p = static_cast<const wire::TimePage*>(mapping_.data());
  for (int tries = 0; tries < kTimePageTries; ++tries) {
    if (tries >= kTimePageSpinTries) ::sched_yield();
    const std::uint64_t s1 = p->sequence.load(std::memory_order_acquire);
    if ((s1 & 1U) != 0) continue;
    const std::uint64_t now = p->now_ns.load(std::memory_order_acquire);
    const std::uint32_t mode = p->mode.load(std::memory_order_acquire);
    const std::uint32_t epoch = p->epoch.load(std::memory_order_acquire);
    if (p->sequence.load(std::memory_order_relaxed) != s1) continue;
    TimeSample out;
    out.now = Nanos(static_cast<std::int64_t>(now));
    out.mode = mode < kModeCount ? static_cast<SrMode>(mode) : SrMode::SC;
    out.epoch = Epoch(epoch);
    return out;
  }
  return std::nullopt;
}

TimeSample TimePageReader::read() const {
  if (auto sample = try_read()) {
    last_ = *sample;
    return *sample;
  }
  ++stalls_;
  return last_;
}

}  // namespace rejuv::clock
