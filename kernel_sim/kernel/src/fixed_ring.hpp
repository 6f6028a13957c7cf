// A bounded FIFO with storage allocated once (no allocation on the routing path).
#pragma once

#include <cstddef>
#include <vector>

#include "rejuv/core/result.hpp"

namespace rejuv::kernel {

template <class T>
class FixedRing {
 public:
  explicit FixedRing(std::size_t capacity) : items_(capacity) {}
  [[nodiscard]] bool push(const T& item) {
    if (size_ == items_.size()) return false;
    items_[(head_ + size_) % items_.size()] = item;
    ++size_;
    return true;
  }
  [[nodiscard]] T pop() {
    REJUV_ASSERT(size_ > 0, "pop from an empty ring");
    T item = items_[head_];
    head_ = (head_ + 1) % items_.size();
    --size_;
    return item;
  }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  [[nodiscard]] std::size_t size() const { return size_; }
  void clear() {
    head_ = 0;
    size_ = 0;
  }

 private:
  std::vector<T> items_;
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

}  // namespace rejuv::kernel
