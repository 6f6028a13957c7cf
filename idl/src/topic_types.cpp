#include "rejuv/msgs/topic_types.hpp"

#include <array>
#include <type_traits>

namespace rejuv::msgs {

namespace {

// Payloads are copied as bytes through channels and rings: every topic struct must be trivially copyable.
#define REJUV_CHECK_POD(CType, Name) \
  static_assert(std::is_trivially_copyable_v<CType>, Name " must be a fixed-size struct");
REJUV_TOPIC_TYPES(REJUV_CHECK_POD)
#undef REJUV_CHECK_POD

#define REJUV_TOPIC_ENTRY(CType, Name) TopicType{Name, sizeof(CType), alignof(CType), &CType##_desc},
constexpr std::array kTypes{REJUV_TOPIC_TYPES(REJUV_TOPIC_ENTRY)};
#undef REJUV_TOPIC_ENTRY

}  // namespace

std::span<const TopicType> all_topic_types() { return kTypes; }

const TopicType* find_topic_type(std::string_view name) {
  for (const TopicType& t : kTypes) {
    if (t.name == name) {
      return &t;
    }
  }
  return nullptr;
}

}  // namespace rejuv::msgs
