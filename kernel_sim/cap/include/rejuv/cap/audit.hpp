// The record of denied invocations (docs/design.md §3: "every denial is counted and written to the audit log with
// service, slot, operation and mode"). The kernel drains it into SecurityEvent topics (idl/sr.idl) and the
// run summary's `denials` by kind. Recording never allocates: both structures are sized once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rejuv/cap/capability.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::cap {

// One denied invocation: who named what, what they asked, why it was refused and in which SR mode.
// `seq` numbers denials from 0 in the order they happened, so a reader can resume where it stopped even
// after the ring has wrapped. `service` is the id as the caller presented it (may be unknown).
struct Denial {
  std::uint64_t seq = 0;
  Nanos at{0};  // kernel time when refused (CapSystem::set_time)
  ServiceId service;
  Slot slot;
  Operation operation = Operation::Publish;
  CapError error = CapError::EmptySlot;
  SrMode mode = SrMode::SC;
  friend constexpr bool operator==(const Denial&, const Denial&) = default;
};

// A bounded ring of the most recent denials. When full, the oldest entry is overwritten and counted in
// `overwritten()`, so a flood of denials (an attacker probing slots) can neither grow kernel memory nor
// hide that it happened. Indexing is oldest first.
class AuditLog {
 public:
  explicit AuditLog(std::size_t capacity);  // capacity ≥ 1 (REJUV_ASSERT)

  // Appends `d` with the next sequence number (d.seq is ignored); O(1), never allocates.
  void push(Denial d) noexcept;

  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] std::size_t capacity() const { return ring_.size(); }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  // Every denial ever pushed (= next sequence number).
  [[nodiscard]] std::uint64_t pushed() const { return pushed_; }
  // Denials lost to wrap-around: pushed() − size().
  [[nodiscard]] std::uint64_t overwritten() const { return pushed_ - size_; }
  // The i-th retained denial, oldest first; i < size() (REJUV_ASSERT).
  [[nodiscard]] const Denial& operator[](std::size_t i) const;
  [[nodiscard]] const Denial& newest() const { return (*this)[size_ - 1]; }
  // Index of the first retained denial with seq ≥ `seq` (size() when none), for incremental draining.
  [[nodiscard]] std::size_t first_index_from(std::uint64_t seq) const;

 private:
  std::vector<Denial> ring_;
  std::size_t head_ = 0;  // where the next push goes
  std::size_t size_ = 0;
  std::uint64_t pushed_ = 0;
};

// Counts of every denial by (service, error, operation), never reset, never wrapping in practice (u64).
// Denials whose service id names no service (NoSuchService) are counted apart in `unknown_service()`,
// and out-of-range operation values apart in `invalid_operation()`, so that no count is misattributed.
class DenialCounters {
 public:
  explicit DenialCounters(std::size_t services);

  void record(ServiceId service, CapError error, Operation op) noexcept;

  [[nodiscard]] std::uint64_t total() const { return total_; }
  [[nodiscard]] std::uint64_t at(ServiceId service, CapError error, Operation op) const;
  [[nodiscard]] std::uint64_t by_service(ServiceId service) const;  // 0 for an unknown id
  [[nodiscard]] std::uint64_t by_error(CapError error) const;
  [[nodiscard]] std::uint64_t by_operation(Operation op) const;
  [[nodiscard]] std::uint64_t unknown_service() const;
  [[nodiscard]] std::uint64_t invalid_operation() const;

 private:
  static constexpr std::size_t kOpColumns = kOperationCount + 1;  // last column: invalid operation value
  [[nodiscard]] std::size_t row_of(ServiceId service) const;
  [[nodiscard]] static std::size_t column_of(Operation op);
  [[nodiscard]] std::size_t cell(std::size_t row, CapError error, std::size_t column) const;

  std::size_t services_;
  std::vector<std::uint64_t> counts_;  // (services_ + 1) rows × kCapErrorCount × kOpColumns
  std::uint64_t total_ = 0;
};

}  // namespace rejuv::cap
