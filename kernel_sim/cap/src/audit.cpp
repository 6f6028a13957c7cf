#include "rejuv/cap/audit.hpp"

#include "rejuv/core/result.hpp"

namespace rejuv::cap {

AuditLog::AuditLog(std::size_t capacity) : ring_(capacity) {
  REJUV_ASSERT(capacity > 0, "an audit log holds at least one denial");
}

void AuditLog::push(Denial d) noexcept {
  d.seq = pushed_++;
  ring_[head_] = d;
  head_ = head_ + 1 == ring_.size() ? 0 : head_ + 1;
  if (size_ < ring_.size()) {
    ++size_;
  }
}

const Denial& AuditLog::operator[](std::size_t i) const {
  REJUV_ASSERT(i < size_, "audit log index out of range");
  // The oldest retained entry sits at head_ once the ring is full, at 0 before.
  const std::size_t oldest = size_ < ring_.size() ? 0 : head_;
  const std::size_t at = oldest + i;
  return ring_[at < ring_.size() ? at : at - ring_.size()];
}

std::size_t AuditLog::first_index_from(std::uint64_t seq) const {
  const std::uint64_t oldest_seq = pushed_ - size_;
  if (seq <= oldest_seq) {
    return 0;
  }
  const std::uint64_t offset = seq - oldest_seq;
  return offset >= size_ ? size_ : static_cast<std::size_t>(offset);
}

DenialCounters::DenialCounters(std::size_t services)
    : services_(services), counts_((services + 1) * kCapErrorCount * kOpColumns, 0) {}

std::size_t DenialCounters::row_of(ServiceId service) const {
  return service.value() < services_ ? service.value() : services_;
}

std::size_t DenialCounters::column_of(Operation op) {
  const auto column = static_cast<std::size_t>(op);
  return column < kOperationCount ? column : kOperationCount;
}

std::size_t DenialCounters::cell(std::size_t row, CapError error, std::size_t column) const {
  const auto e = static_cast<std::size_t>(error);
  REJUV_ASSERT(e < kCapErrorCount, "CapError out of range");
  return (row * kCapErrorCount + e) * kOpColumns + column;
}

void DenialCounters::record(ServiceId service, CapError error, Operation op) noexcept {
  ++counts_[cell(row_of(service), error, column_of(op))];
  ++total_;
}

std::uint64_t DenialCounters::at(ServiceId service, CapError error, Operation op) const {
  if (service.value() >= services_) {
    return 0;
  }
  return counts_[cell(service.value(), error, column_of(op))];
}

std::uint64_t DenialCounters::by_service(ServiceId service) const {
  if (service.value() >= services_) {
    return 0;
  }
  std::uint64_t sum = 0;
  for (const CapError e : kAllCapErrors) {
    for (std::size_t c = 0; c < kOpColumns; ++c) {
      sum += counts_[cell(service.value(), e, c)];
    }
  }
  return sum;
}

std::uint64_t DenialCounters::by_error(CapError error) const {
  std::uint64_t sum = 0;
  for (std::size_t r = 0; r <= services_; ++r) {
    for (std::size_t c = 0; c < kOpColumns; ++c) {
      sum += counts_[cell(r, error, c)];
    }
  }
  return sum;
}

std::uint64_t DenialCounters::by_operation(Operation op) const {
  std::uint64_t sum = 0;
  for (std::size_t r = 0; r <= services_; ++r) {
    for (const CapError e : kAllCapErrors) {
      sum += counts_[cell(r, e, column_of(op))];
    }
  }
  return sum;
}

std::uint64_t DenialCounters::unknown_service() const {
  std::uint64_t sum = 0;
  for (const CapError e : kAllCapErrors) {
    for (std::size_t c = 0; c < kOpColumns; ++c) {
      sum += counts_[cell(services_, e, c)];
    }
  }
  return sum;
}

std::uint64_t DenialCounters::invalid_operation() const {
  std::uint64_t sum = 0;
  for (std::size_t r = 0; r <= services_; ++r) {
    for (const CapError e : kAllCapErrors) {
      sum += counts_[cell(r, e, kOperationCount)];
    }
  }
  return sum;
}

}  // namespace rejuv::cap
