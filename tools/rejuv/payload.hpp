// A routed message's payload as its C struct, for the observers of `rejuv run` (run_recorder, ulog_recorder).
#pragma once

#include <algorithm>
#include <cstring>
#include <span>

#include "rejuv/kernel/kernel.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::cli {

// The payload copied into a T (the kernel checked its size against the topic's type on publish).
template <class T>
T payload_as(std::span<const std::byte> payload) {
  T v{};
  std::memcpy(&v, payload.data(), std::min(sizeof(T), payload.size()));
  return v;
}

// Whether the publication's topic carries T.
template <class T>
bool carries(const kernel::Publication& p) {
  return p.type == msgs::TopicTraits<T>::name;
}

}  // namespace rejuv::cli
