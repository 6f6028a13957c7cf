// Capabilities as values, the operations a service can invoke through them and the one error enum of
// every capability invocation (DESIGN §3; seL4 style: a cap is {object, rights, badge} in a CSpace slot).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::cap {

// A badge is the tag a minter stamps on a derived capability (seL4 Mint) so that whoever receives an
// invocation can tell which delegation it came through. 0 means unbadged; the kernel mints the policy's
// caps unbadged, and only an unbadged cap can be minted with a badge (a badge is never overwritten).
using Badge = StrongId<struct BadgeTag, std::uint64_t>;
inline constexpr Badge kNoBadge{0};

// A capability: the authority to invoke `object` (of kind `kind`) with `rights`, tagged with `badge`.
// A small value; it lives in a slot of a CSpace and is only ever read or written by the kernel. Derived
// caps never hold a right their parent lacks (DESIGN §3).
struct Capability {
  ObjectId object;
  ObjectKind kind = ObjectKind::Topic;
  Rights rights;
  Badge badge;
  friend constexpr bool operator==(const Capability&, const Capability&) = default;
};

// The CSpace of the kernel itself, which holds the original capability of every object (slot = ObjectId).
// No service can name it: it is not a valid ServiceId for any invocation.
inline constexpr ServiceId kKernelSpace{0xFFFF'FFFFU};

// Where a capability lives: a slot of a service's CSpace, or (space == kKernelSpace) the kernel's original
// of object `slot`. Used by the kernel and by tests to walk the derivation tree; services only ever name
// slots of their own CSpace, by Slot alone.
struct CapRef {
  ServiceId space;
  Slot slot;
  [[nodiscard]] constexpr bool is_original() const { return space == kKernelSpace; }
  friend constexpr auto operator<=>(const CapRef&, const CapRef&) = default;
};

// What a service asks the kernel to do with a capability. The data-plane operations are carried out by
// the component that owns the object (broker, image store, timer, network gate, persistent store, mode
// manager) after `decode` has validated them; the cap-management ones (Copy, Mint, Revoke, Delete) are
// carried out by CapSystem::invoke. The numeric values travel on the wire and in SecurityEvent.operation.
enum class Operation : std::uint8_t {
  Publish,             // Topic + Write
  Subscribe,           // Topic + Read
  CheckpointCreate,    // Checkpoint + Write (§V: create_checkpoint)
  CheckpointRollback,  // Checkpoint + Write (§V: rollback now)
  TimerArm,            // Checkpoint + Write (§V-A: do_timer, the rejuvenation timer)
  NetSend,             // Network + Write
  NetReceive,          // Network + Read
  LimitsWrite,         // Limits + Write (§IV-C: set the restricted limits Ū)
  LimitsRead,          // Limits + Read (§IV-C: only the output driver applies them)
  PersistentRead,      // Persistent + Read (§III: persistent data)
  PersistentWrite,     // Persistent + Write
  ModeRequest,         // Mode + Write (Fig. 1 transitions requested by checkpoint_p)
  Copy,                // any kind + Grant on the source (seL4 CNode_Copy)
  Mint,                // any kind + Grant on the source, sets a badge (seL4 CNode_Mint)
  Revoke,              // any kind, no right: deletes every descendant of the cap
  Delete,              // any kind, no right: deletes the cap and every descendant
};
inline constexpr std::array kAllOperations{
    Operation::Publish,        Operation::Subscribe,      Operation::CheckpointCreate,
    Operation::CheckpointRollback, Operation::TimerArm,   Operation::NetSend,
    Operation::NetReceive,     Operation::LimitsWrite,    Operation::LimitsRead,
    Operation::PersistentRead, Operation::PersistentWrite, Operation::ModeRequest,
    Operation::Copy,           Operation::Mint,           Operation::Revoke,
    Operation::Delete};
inline constexpr std::size_t kOperationCount = kAllOperations.size();
[[nodiscard]] std::string_view to_string(Operation op);
// An operation from its wire value (SecurityEvent, channel messages); nullopt when out of range.
[[nodiscard]] std::optional<Operation> operation_from_wire(std::uint8_t value);

// What the invoked capability must be for an operation: its object kind (any kind when `any_kind`) and
// the rights it must hold. Derived from DESIGN §3; `decode` checks exactly this.
struct Requirement {
  bool any_kind = false;
  ObjectKind kind = ObjectKind::Topic;
  Rights rights;
};
[[nodiscard]] constexpr Requirement requirement(Operation op) {
  switch (op) {
    case Operation::Publish: return {.kind = ObjectKind::Topic, .rights = Right::Write};
    case Operation::Subscribe: return {.kind = ObjectKind::Topic, .rights = Right::Read};
    case Operation::CheckpointCreate:
    case Operation::CheckpointRollback:
    case Operation::TimerArm: return {.kind = ObjectKind::Checkpoint, .rights = Right::Write};
    case Operation::NetSend: return {.kind = ObjectKind::Network, .rights = Right::Write};
    case Operation::NetReceive: return {.kind = ObjectKind::Network, .rights = Right::Read};
    case Operation::LimitsWrite: return {.kind = ObjectKind::Limits, .rights = Right::Write};
    case Operation::LimitsRead: return {.kind = ObjectKind::Limits, .rights = Right::Read};
    case Operation::PersistentRead: return {.kind = ObjectKind::Persistent, .rights = Right::Read};
    case Operation::PersistentWrite: return {.kind = ObjectKind::Persistent, .rights = Right::Write};
    case Operation::ModeRequest: return {.kind = ObjectKind::Mode, .rights = Right::Write};
    case Operation::Copy:
    case Operation::Mint: return {.any_kind = true, .rights = Right::Grant};
    case Operation::Revoke:
    case Operation::Delete: return {.any_kind = true, .rights = Rights::none()};
  }
  // Unreachable for a valid Operation; CapSystem::decode refuses out-of-range values before asking.
  return {.any_kind = false, .kind = ObjectKind::Topic, .rights = Rights::all()};
}

// True for the operations CapSystem::invoke carries out itself (they change CSpaces).
[[nodiscard]] constexpr bool is_cap_management(Operation op) {
  switch (op) {
    case Operation::Copy:
    case Operation::Mint:
    case Operation::Revoke:
    case Operation::Delete: return true;
    case Operation::Publish:
    case Operation::Subscribe:
    case Operation::CheckpointCreate:
    case Operation::CheckpointRollback:
    case Operation::TimerArm:
    case Operation::NetSend:
    case Operation::NetReceive:
    case Operation::LimitsWrite:
    case Operation::LimitsRead:
    case Operation::PersistentRead:
    case Operation::PersistentWrite:
    case Operation::ModeRequest: return false;
  }
  return false;
}

// Why a capability invocation (or a kernel-side lookup) was refused. One enum for the whole family
// (CONVENTIONS "Errors are values"); the numeric values travel in SecurityEvent.error.
enum class CapError : std::uint8_t {
  NoSuchService,       // the caller (or a Transfer's receiver) is not a service of the graph
  SlotOutOfRange,      // a slot index ≥ the CSpace size
  EmptySlot,           // the named slot holds no capability
  SlotOccupied,        // the destination slot of a Copy/Mint already holds a capability
  ReservedSlot,        // the destination is a slot the mode table reserves for a policy cap
  CSpaceFull,          // a Transfer's receiver has no free unreserved slot
  WrongObject,         // the cap names an object of another kind than the operation needs
  InsufficientRights,  // the cap lacks a right the operation needs
  BadArgument,         // an argument is malformed, missing, of the wrong form or would yield a useless cap
  NoSuchObject,        // a name or ObjectId that names no object
};
inline constexpr std::array kAllCapErrors{
    CapError::NoSuchService, CapError::SlotOutOfRange, CapError::EmptySlot,
    CapError::SlotOccupied,  CapError::ReservedSlot,   CapError::CSpaceFull,
    CapError::WrongObject,   CapError::InsufficientRights, CapError::BadArgument,
    CapError::NoSuchObject};
inline constexpr std::size_t kCapErrorCount = kAllCapErrors.size();
[[nodiscard]] std::string_view to_string(CapError error);

}  // namespace rejuv::cap
