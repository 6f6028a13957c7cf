// The per-mode capability table: what the policy compiles to and what a mode transition applies
// (docs/design.md §3–§4). Every capability a service may ever hold has one fixed slot; in a mode where the policy
// grants nothing for it, the slot is empty. A mode transition is revoke + mint of the slots that change.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::cap {

// A kernel object the policy names: its id (= its index in ModeTable::objects), kind and policy name.
// The capability kernel creates each one and holds its original capability.
struct ObjectSpec {
  ObjectId id;          // index into ModeTable::objects
  ObjectKind kind;
  std::string name;
};

// The one fixed slot that a service may ever hold a capability to one object in, and the rights that
// slot holds in each mode. A (service, slot) and a (service, object) each appear at most once.
struct SlotGrant {
  ServiceId service;    // index into ModeTable::services
  Slot slot;            // fixed slot in that service's CSpace (its boot info maps name → slot)
  ObjectId object;
  std::array<Rights, kModeCount> rights;  // by index_of(mode); Rights::none() = slot empty in that mode
};

// The policy compiled for the capability kernel: services and objects by index, and every policy slot.
// CapSystem::create validates it and builds the CSpaces; CapSystem::apply_mode applies one mode of it.
struct ModeTable {
  std::vector<std::string> services;  // ServiceId = index
  std::vector<ObjectSpec> objects;    // ObjectId = index
  std::vector<SlotGrant> slots;
};

}  // namespace rejuv::cap
