// Capabilities as values, the operations a service can invoke through them and the one error enum of
// every capability invocation (docs/design.md §3; seL4 style: a cap is {object, rights, badge} in a CSpace slot).
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
// caps never hold a right their parent lacks (docs/design.md §3).
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
// the rights it must hold. Derived from docs/design.md §3; `decode` checks exactly this.
struct Requirement {
  bool any_kind = false;
  ObjectKind kind = ObjectKind::Topic;
  Rights rights;
};

// The one table of operations (docs/design.md §3), in wire order: which object kind each acts on (any kind: the
// capability management of seL4's CNode, carried out by CapSystem::invoke) and the rights it needs.
// CapSystem::decode checks the requirement; the kernel decodes an Invoke's arguments per the row's kind
// and invokes it on the part of the kernel that owns that kind (kernel_sim/kernel/src/invocation.hpp).
struct OperationSpec {
  Operation op;
  Requirement need;
};
inline constexpr std::array<OperationSpec, 16> kOperations{{
    {Operation::Publish, {.kind = ObjectKind::Topic, .rights = Right::Write}},
    {Operation::Subscribe, {.kind = ObjectKind::Topic, .rights = Right::Read}},
    {Operation::CheckpointCreate, {.kind = ObjectKind::Checkpoint, .rights = Right::Write}},
    {Operation::CheckpointRollback, {.kind = ObjectKind::Checkpoint, .rights = Right::Write}},
    {Operation::TimerArm, {.kind = ObjectKind::Checkpoint, .rights = Right::Write}},
    {Operation::NetSend, {.kind = ObjectKind::Network, .rights = Right::Write}},
    {Operation::NetReceive, {.kind = ObjectKind::Network, .rights = Right::Read}},
    {Operation::LimitsWrite, {.kind = ObjectKind::Limits, .rights = Right::Write}},
    {Operation::LimitsRead, {.kind = ObjectKind::Limits, .rights = Right::Read}},
    {Operation::PersistentRead, {.kind = ObjectKind::Persistent, .rights = Right::Read}},
    {Operation::PersistentWrite, {.kind = ObjectKind::Persistent, .rights = Right::Write}},
    {Operation::ModeRequest, {.kind = ObjectKind::Mode, .rights = Right::Write}},
    {Operation::Copy, {.any_kind = true, .rights = Right::Grant}},
    {Operation::Mint, {.any_kind = true, .rights = Right::Grant}},
    {Operation::Revoke, {.any_kind = true, .rights = Rights::none()}},
    {Operation::Delete, {.any_kind = true, .rights = Rights::none()}},
}};
static_assert(kOperations.size() == kOperationCount);
static_assert([] {
  for (std::size_t i = 0; i < kOperations.size(); ++i) {
    if (kOperations[i].op != kAllOperations[i]) return false;
  }
  return true;
}(), "kOperations is in wire order, one row per operation");

[[nodiscard]] constexpr Requirement requirement(Operation op) {
  const auto i = static_cast<std::size_t>(op);
  // Unreachable for a valid Operation; CapSystem::decode refuses out-of-range values before asking.
  if (i >= kOperations.size()) return {.any_kind = false, .kind = ObjectKind::Topic, .rights = Rights::all()};
  return kOperations[i].need;
}

// True for the operations CapSystem::invoke carries out itself (they change CSpaces): those of any kind.
[[nodiscard]] constexpr bool is_cap_management(Operation op) { return requirement(op).any_kind; }

// The capability-management operations alone (seL4's CNode calls), for code that carries out only those: a
// switch over CapManagement is exhaustive without naming a data-plane operation. nullopt for the others.
enum class CapManagement : std::uint8_t { Copy, Mint, Revoke, Delete };
[[nodiscard]] constexpr std::optional<CapManagement> management_of(Operation op) {
  if (!is_cap_management(op)) return std::nullopt;
  if (op == Operation::Copy) return CapManagement::Copy;
  if (op == Operation::Mint) return CapManagement::Mint;
  if (op == Operation::Revoke) return CapManagement::Revoke;
  if (op == Operation::Delete) return CapManagement::Delete;
  return std::nullopt;
}
static_assert([] {
  for (const Operation op : kAllOperations) {
    if (management_of(op).has_value() != is_cap_management(op)) return false;
  }
  return true;
}(), "every operation of any kind has its CapManagement");

// Why a capability invocation (or a kernel-side lookup) was refused. One enum for the whole family
// (docs/conventions.md "Errors are values"); the numeric values travel in SecurityEvent.error.
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
