// Strong types for identifiers (docs/conventions.md "Types say what they mean"): a ServiceId is not a Slot.
#pragma once

#include <compare>
#include <cstdint>
#include <functional>

namespace rejuv {

// An integer identifier that only compares with identifiers of the same Tag.
template <class Tag, class Rep = std::uint32_t>
class StrongId {
 public:
  using rep = Rep;
  constexpr StrongId() = default;
  constexpr explicit StrongId(Rep value) : value_(value) {}
  [[nodiscard]] constexpr Rep value() const { return value_; }
  friend constexpr auto operator<=>(StrongId, StrongId) = default;

 private:
  Rep value_{};
};

using ServiceId = StrongId<struct ServiceIdTag>;         // index of a service in the graph
using ObjectId = StrongId<struct ObjectIdTag>;           // index of a kernel object
using Slot = StrongId<struct SlotTag>;                   // CPtr: index into a service's CSpace
using Generation = StrongId<struct GenerationTag, std::uint64_t>;  // checkpoint generation g
using Epoch = StrongId<struct EpochTag>;                 // rollback epoch (incremented per rollback)

}  // namespace rejuv

template <class Tag, class Rep>
struct std::hash<rejuv::StrongId<Tag, Rep>> {
  std::size_t operator()(rejuv::StrongId<Tag, Rep> id) const noexcept {
    return std::hash<Rep>{}(id.value());
  }
};
