// Messages held for lockstep determinism (docs/design.md §6; router.cpp): a service's publications read during a
// routing round, and the DDS samples a step covers, handed out at the end of the round in canonical order —
// sorted by their key, ties in arrival order — whatever the scheduling that brought them in. The bytes are
// copied in as they arrive; the buffers keep their capacity from round to round.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <span>
#include <vector>

#include "rejuv/core/result.hpp"

namespace rejuv::kernel {

template <typename Key, typename Tag>
class CanonicalStage {
 public:
  void add(const Key& key, const Tag& tag, std::span<const std::byte> bytes) {
    REJUV_ASSERT(!draining_, "nothing is staged while the stage is handed out");
    entries_.push_back(Entry{.key = key, .tag = tag, .offset = bytes_.size(), .size = bytes.size()});
    bytes_.insert(bytes_.end(), bytes.begin(), bytes.end());
  }
  // Calls f(key, tag, bytes) for every entry in canonical order, then empties the stage.
  template <typename F>
  void drain(F&& f) {
    if (entries_.empty()) return;
    order_.resize(entries_.size());
    std::iota(order_.begin(), order_.end(), std::size_t{0});
    std::stable_sort(order_.begin(), order_.end(),
                     [&](std::size_t a, std::size_t b) { return entries_[a].key < entries_[b].key; });
    draining_ = true;
    for (const std::size_t i : order_) {
      const Entry& e = entries_[i];
      f(e.key, e.tag, std::span<const std::byte>(bytes_).subspan(e.offset, e.size));
    }
    draining_ = false;
    entries_.clear();
    bytes_.clear();
  }
  // Drops the entries for which p(key, tag) holds. Their bytes stay until the next drain, or go at once when no
  // entry is left: a stage emptied this way (a rollback drops what the rejuvenated services staged) is not
  // drained until something new is staged, and must not hold what it dropped meanwhile.
  template <typename P>
  void erase_if(P&& p) {
    std::erase_if(entries_, [&](const Entry& e) { return p(e.key, e.tag); });
    if (entries_.empty()) bytes_.clear();
  }
  [[nodiscard]] bool empty() const { return entries_.empty(); }
  [[nodiscard]] std::size_t size() const { return entries_.size(); }
  [[nodiscard]] std::size_t bytes_held() const { return bytes_.size(); }  // the staged entries' and dropped ones'

 private:
  struct Entry {
    Key key{};
    Tag tag{};
    std::size_t offset = 0;
    std::size_t size = 0;
  };
  std::vector<Entry> entries_;
  std::vector<std::byte> bytes_;
  std::vector<std::size_t> order_;  // sort scratch
  bool draining_ = false;
};

}  // namespace rejuv::kernel
