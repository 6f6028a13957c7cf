// The words every component shares: object kinds, rights and CPS SR modes (docs/design.md §3, §8; paper Fig. 1).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rejuv {

// Kinds of kernel object a capability can name (docs/design.md §3).
enum class ObjectKind : std::uint8_t { Topic, Checkpoint, Network, Limits, Persistent, Mode };
inline constexpr std::array kAllObjectKinds{ObjectKind::Topic,  ObjectKind::Checkpoint,
                                            ObjectKind::Network, ObjectKind::Limits,
                                            ObjectKind::Persistent, ObjectKind::Mode};
[[nodiscard]] std::string_view to_string(ObjectKind kind);

// CPS SR modes (Fig. 1): MC → RB → SC → Update → CP → MC.
enum class SrMode : std::uint8_t { MC, RB, SC, Update, CP };
inline constexpr std::array kAllModes{SrMode::MC, SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP};
inline constexpr std::size_t kModeCount = kAllModes.size();
[[nodiscard]] std::string_view to_string(SrMode mode);
[[nodiscard]] constexpr std::size_t index_of(SrMode mode) { return static_cast<std::size_t>(mode); }
// The secure execution interval (§II): every mode but MC has the network off.
[[nodiscard]] constexpr bool in_secure_interval(SrMode mode) { return mode != SrMode::MC; }

// Rights of a capability (seL4): Read, Write, Grant. A set of them, as a small value.
enum class Right : std::uint8_t { Read = 1U << 0U, Write = 1U << 1U, Grant = 1U << 2U };

class Rights {
 public:
  constexpr Rights() = default;
  constexpr Rights(Right r) : bits_(static_cast<std::uint8_t>(r)) {}  // NOLINT(google-explicit-constructor)
  [[nodiscard]] static constexpr Rights none() { return {}; }
  [[nodiscard]] static constexpr Rights all() { return Rights{Right::Read} | Right::Write | Right::Grant; }
  // Parses letters from "RWG" (each at most once, at least one); nullopt on anything else.
  [[nodiscard]] static std::optional<Rights> parse(std::string_view letters);

  [[nodiscard]] constexpr bool has(Right r) const { return (bits_ & static_cast<std::uint8_t>(r)) != 0; }
  [[nodiscard]] constexpr bool contains(Rights other) const { return (bits_ & other.bits_) == other.bits_; }
  [[nodiscard]] constexpr bool intersects(Rights other) const { return (bits_ & other.bits_) != 0; }
  [[nodiscard]] constexpr bool empty() const { return bits_ == 0; }
  [[nodiscard]] constexpr std::uint8_t bits() const { return bits_; }
  // "RWG" with '-' for a missing right, e.g. "RW-".
  [[nodiscard]] std::string to_string() const;
  // Only the letters held, e.g. "RW"; "" when none.
  [[nodiscard]] std::string letters() const;

  friend constexpr Rights operator|(Rights a, Rights b) { return Rights(static_cast<std::uint8_t>(a.bits_ | b.bits_)); }
  friend constexpr Rights operator&(Rights a, Rights b) { return Rights(static_cast<std::uint8_t>(a.bits_ & b.bits_)); }
  friend constexpr bool operator==(Rights, Rights) = default;

 private:
  constexpr explicit Rights(std::uint8_t bits) : bits_(bits) {}
  std::uint8_t bits_{0};
};

// A set of modes, e.g. the modes in which a grant holds.
class ModeSet {
 public:
  constexpr ModeSet() = default;
  [[nodiscard]] static constexpr ModeSet all() { return ModeSet(static_cast<std::uint8_t>((1U << kModeCount) - 1U)); }
  constexpr ModeSet& add(SrMode m) { bits_ = static_cast<std::uint8_t>(bits_ | bit(m)); return *this; }
  [[nodiscard]] constexpr bool has(SrMode m) const { return (bits_ & bit(m)) != 0; }
  [[nodiscard]] constexpr bool empty() const { return bits_ == 0; }
  [[nodiscard]] constexpr bool intersects(ModeSet o) const { return (bits_ & o.bits_) != 0; }
  [[nodiscard]] std::string to_string() const;  // e.g. "RB,SC,CP"
  friend constexpr bool operator==(ModeSet, ModeSet) = default;

 private:
  constexpr explicit ModeSet(std::uint8_t bits) : bits_(bits) {}
  static constexpr std::uint8_t bit(SrMode m) { return static_cast<std::uint8_t>(1U << index_of(m)); }
  std::uint8_t bits_{0};
};

}  // namespace rejuv
