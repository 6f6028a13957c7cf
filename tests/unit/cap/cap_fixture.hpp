// A small synthetic mode table shaped like the real policy (docs/design.md §4, §8), shared by the cap tests.
#pragma once

#include <initializer_list>
#include <utility>

#include "rejuv/cap/cap_system.hpp"

namespace rejuv::cap::testing {

// Services and objects of the fixture, by index.
inline constexpr ServiceId kSensors{0};
inline constexpr ServiceId kExtLink{1};
inline constexpr ServiceId kCheckpointP{2};
inline constexpr ObjectId kImu{0};       // Topic
inline constexpr ObjectId kNet{1};       // Network
inline constexpr ObjectId kCkpt{2};      // Checkpoint
inline constexpr ObjectId kLimits{3};    // Limits
inline constexpr ObjectId kCell{4};      // Persistent
inline constexpr ObjectId kMode{5};      // Mode
inline constexpr ObjectId kSetpoint{6};  // Topic

inline Rights rights_of(const char* letters) { return *Rights::parse(letters); }

// `r` in the listed modes, none elsewhere.
inline std::array<Rights, kModeCount> in_modes(Rights r, std::initializer_list<SrMode> modes) {
  std::array<Rights, kModeCount> out{};
  for (const SrMode m : modes) {
    out[index_of(m)] = r;
  }
  return out;
}
inline std::array<Rights, kModeCount> always(Rights r) {
  return in_modes(r, {SrMode::MC, SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP});
}

// sensors:      s0 imu RWG always; s1 cell R in MC only; s2 setpoint RWG in SC, R in MC.
// ext_link:     s0 net RW in MC only (§III SEI); s1 imu R always.
// checkpoint_p: s0 ckpt W outside MC (§III timer); s1 limits W in SC/Update/CP; s2 cell RW; s3 mode W.
inline ModeTable fixture_table() {
  ModeTable t;
  t.services = {"sensors", "ext_link", "checkpoint_p"};
  t.objects = {
      {.id = kImu, .kind = ObjectKind::Topic, .name = "imu"},
      {.id = kNet, .kind = ObjectKind::Network, .name = "net"},
      {.id = kCkpt, .kind = ObjectKind::Checkpoint, .name = "ckpt"},
      {.id = kLimits, .kind = ObjectKind::Limits, .name = "limits"},
      {.id = kCell, .kind = ObjectKind::Persistent, .name = "cell"},
      {.id = kMode, .kind = ObjectKind::Mode, .name = "mode"},
      {.id = kSetpoint, .kind = ObjectKind::Topic, .name = "setpoint"},
  };
  auto setpoint = in_modes(rights_of("RWG"), {SrMode::SC});
  setpoint[index_of(SrMode::MC)] = rights_of("R");
  t.slots = {
      {.service = kSensors, .slot = Slot{0}, .object = kImu, .rights = always(rights_of("RWG"))},
      {.service = kSensors, .slot = Slot{1}, .object = kCell, .rights = in_modes(rights_of("R"), {SrMode::MC})},
      {.service = kSensors, .slot = Slot{2}, .object = kSetpoint, .rights = setpoint},
      {.service = kExtLink, .slot = Slot{0}, .object = kNet, .rights = in_modes(rights_of("RW"), {SrMode::MC})},
      {.service = kExtLink, .slot = Slot{1}, .object = kImu, .rights = always(rights_of("R"))},
      {.service = kCheckpointP,
       .slot = Slot{0},
       .object = kCkpt,
       .rights = in_modes(rights_of("W"), {SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP})},
      {.service = kCheckpointP,
       .slot = Slot{1},
       .object = kLimits,
       .rights = in_modes(rights_of("W"), {SrMode::SC, SrMode::Update, SrMode::CP})},
      {.service = kCheckpointP, .slot = Slot{2}, .object = kCell, .rights = always(rights_of("RW"))},
      {.service = kCheckpointP, .slot = Slot{3}, .object = kMode, .rights = always(rights_of("W"))},
  };
  return t;
}

inline CapSystem make_system(const CapSystemConfig& config = {}) {
  auto sys = CapSystem::create(fixture_table(), config);
  REJUV_ASSERT(sys.has_value(), "fixture table is valid");
  return std::move(*sys);
}

}  // namespace rejuv::cap::testing
