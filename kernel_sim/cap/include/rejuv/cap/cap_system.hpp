// The capability kernel (docs/design.md §3): one CSpace per service, the kernel's originals, the derivation tree,
// decode-then-invoke, per-mode policy application and the denial record.
//
// Trust: every ServiceId passed to `decode` is the identity of the channel the request arrived on (the
// kernel knows it, the service cannot choose it); everything else in a request — slot, operation,
// arguments — is untrusted and fully checked. Not thread-safe: the kernel's event loop owns it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "rejuv/cap/audit.hpp"
#include "rejuv/cap/capability.hpp"
#include "rejuv/cap/mode_table.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::cap {

// ---- Arguments of an invocation (untrusted; `decode` checks every one) ----

// No argument: every data-plane operation, Revoke and Delete. (Payloads are checked by their component,
// e.g. the broker checks a publication's size against the topic type.)
struct NoArgs {
  friend constexpr bool operator==(NoArgs, NoArgs) = default;
};
// Destination of a Copy/Mint in the caller's own CSpace: a free slot it names.
struct OwnSlot {
  Slot slot;
};
// Destination of a Copy/Mint in another service's CSpace (a delegation). The caller cannot name a slot
// there (docs/design.md §2: a service cannot name another's caps); the kernel places the cap in the receiver's
// lowest free slot that the mode table does not reserve and reports it in Performed::placed.
struct Transfer {
  ServiceId to;
};
using Destination = std::variant<OwnSlot, Transfer>;
// Copy: derive a cap with rights = source.rights & mask and the source's badge (seL4 CNode_Copy with a mask).
struct CopyArgs {
  Destination to;
  Rights mask = Rights::all();
};
// Mint: as Copy, and stamp a non-zero badge; the source must be unbadged (seL4 CNode_Mint).
struct MintArgs {
  Destination to;
  Rights mask = Rights::all();
  Badge badge = kNoBadge;
};
using Args = std::variant<NoArgs, CopyArgs, MintArgs>;

// ---- Results ----

class CapSystem;

// The passkey that only CapSystem can make, so that only it can make an Invocation (and can build one in
// place inside a Result, which a private constructor would forbid).
class InvocationKey {
  friend class CapSystem;
  InvocationKey() = default;
};

// A validated request: proof that `caller` may perform `operation` through the cap in `slot`, with every
// argument checked and resolved. Only CapSystem::decode makes one (its constructor needs an InvocationKey),
// so a component handed an Invocation needs no further check; it is valid until the next change to any
// CSpace (CapSystem::invoke asserts that it is not stale). For Copy/Mint it also carries the resolved
// destination and the exact cap that will be placed there.
class Invocation {
 public:
  explicit Invocation(InvocationKey /*only CapSystem*/) {}

  [[nodiscard]] ServiceId caller() const { return caller_; }
  [[nodiscard]] Slot slot() const { return slot_; }
  [[nodiscard]] Operation operation() const { return operation_; }
  [[nodiscard]] ObjectId object() const { return cap_.object; }
  [[nodiscard]] ObjectKind kind() const { return cap_.kind; }
  [[nodiscard]] Badge badge() const { return cap_.badge; }
  [[nodiscard]] const Capability& capability() const { return cap_; }  // the invoked cap
  // Copy/Mint only: where the derived cap goes and what it is (same object, masked rights, badge).
  [[nodiscard]] CapRef destination() const { return destination_; }
  [[nodiscard]] Capability derived() const {
    return {.object = cap_.object, .kind = cap_.kind, .rights = derived_rights_, .badge = derived_badge_};
  }

 private:
  friend class CapSystem;

  Capability cap_;
  std::uint64_t version_ = 0;  // CapSystem state version at decode
  ServiceId caller_;
  Slot slot_;
  Operation operation_ = Operation::Publish;
  Rights derived_rights_;
  CapRef destination_;
  Badge derived_badge_;
};

// What CapSystem::invoke did.
struct Performed {
  std::optional<CapRef> placed;  // Copy/Mint: the new cap's location
  std::size_t deleted = 0;       // Revoke/Delete: caps removed, descendants included
};

// Why a mode could not be applied.
enum class ModeError : std::uint8_t {
  UnknownMode,  // not one of kAllModes (a bad cast upstream)
};
[[nodiscard]] std::string_view to_string(ModeError error);

// What a mode transition changed (docs/design.md §3: "a mode transition is revoke + mint").
struct ModeChange {
  SrMode from = SrMode::SC;
  SrMode to = SrMode::SC;
  std::size_t slots_changed = 0;  // policy slots whose content was replaced or emptied
  std::size_t deleted = 0;        // caps removed, copies and other descendants included
  std::size_t minted = 0;         // caps minted from the kernel's originals
};

// Why a ModeTable (the policy compiler's output) cannot be turned into CSpaces. Carries a message naming
// the offending service/object/slot, since it reflects a policy the user wrote.
struct TableError {
  enum class Kind : std::uint8_t {
    BadConfig,         // zero-sized CSpace or audit log, or more slots than the kernel can index
    DuplicateName,     // two services or two objects with the same name
    ObjectIdMismatch,  // objects[i].id != i
    UnknownService,    // a grant names a service outside ModeTable::services
    UnknownObject,     // a grant names an object outside ModeTable::objects
    SlotOutOfRange,    // a grant's slot ≥ the CSpace size
    DuplicateSlot,     // two grants share one (service, slot)
    DuplicateGrant,    // two grants share one (service, object): each needs exactly one fixed slot
  };
  Kind kind;
  std::string message;
  [[nodiscard]] std::string to_string() const;
};
[[nodiscard]] std::string_view to_string(TableError::Kind kind);

// One cap a service may ever hold, as its boot info describes it (docs/design.md §3): the name it knows the
// object by, the fixed slot, the kind, and the rights it holds in each mode (none = slot empty).
struct BootCap {
  std::string name;
  Slot slot;
  ObjectId object;
  ObjectKind kind = ObjectKind::Topic;
  std::array<Rights, kModeCount> rights{};
  [[nodiscard]] Rights rights_in(SrMode mode) const { return rights[index_of(mode)]; }
};

// What a service receives at start: its identity, the size of its CSpace and every cap it may ever hold.
struct BootInfo {
  ServiceId service;
  std::string name;
  std::size_t cspace_slots = 0;
  std::vector<BootCap> caps;  // by slot
  // The cap named `object_name`; NoSuchObject when this service may never hold it.
  [[nodiscard]] Result<BootCap, CapError> find(std::string_view object_name) const;
};

// A full, comparable picture of every capability and derivation edge, for tests and diagnostics
// ("a failed request leaves no trace": compare snapshots before and after).
struct CapRecord {
  CapRef at;
  Capability cap;
  std::optional<CapRef> parent;  // nullopt only for the kernel's originals
  friend bool operator==(const CapRecord&, const CapRecord&) = default;
};
struct CapState {
  SrMode mode = SrMode::SC;
  std::vector<CapRecord> caps;  // ordered by location: originals first, then service by service
  friend bool operator==(const CapState&, const CapState&) = default;
};

// Configuration, set once at creation.
struct CapSystemConfig {
  std::size_t cspace_slots = 256;     // slots per service CSpace
  std::size_t audit_capacity = 4096;  // denials retained in the ring
  SrMode initial_mode = SrMode::SC;   // a safe mode, network off (docs/design.md §7 "Faults": start safe)
};

// The capability kernel. Holds, in one flat array, the kernel's original cap of every object followed by
// one fixed-size CSpace per service; a CPtr is a slot index, so a lookup is bounds check + array index
// (no hashing, no allocation on the invocation path). A derivation tree (parent, first child, siblings)
// links every cap to the cap it was derived from; every service cap descends from an original.
//
// Deleting a cap deletes its descendants too (seL4 leaves them to the grandparent; we cascade so that a
// delegation never outlives the authority it came from, and so that a mode transition, which replaces a
// policy cap, also takes back every copy of it). Revoke deletes the descendants only.
//
// Policy slots (the ModeTable's fixed slot per (service, object)) are reserved: only the kernel writes
// them, in `apply_mode`, so after any transition every policy slot holds exactly the table's rights for
// the mode, as a direct child of the original. Copies go to unreserved slots.
class CapSystem {
 public:
  [[nodiscard]] static Result<CapSystem, TableError> create(const ModeTable& table,
                                                            const CapSystemConfig& config = {});

  CapSystem(CapSystem&&) noexcept = default;
  CapSystem& operator=(CapSystem&&) noexcept = default;
  CapSystem(const CapSystem&) = delete;  // the kernel's authority state exists once
  CapSystem& operator=(const CapSystem&) = delete;
  ~CapSystem() = default;

  // ---- Service invocations (untrusted input) ----

  // Checks, in this order: caller, slot range, slot non-empty, operation value, object kind, rights, then
  // every argument (form, mask, badge, destination). Returns a validated Invocation, or the first error;
  // on error nothing changes except the denial counters and audit log. The hot path of the broker.
  [[nodiscard]] Result<Invocation, CapError> decode(ServiceId caller, Slot slot, Operation op,
                                                    const Args& args = NoArgs{});
  // Carries out a decoded Copy, Mint, Revoke or Delete. Cannot fail: decode checked everything. A
  // data-plane or stale Invocation is a kernel bug (REJUV_ASSERT).
  Performed invoke(const Invocation& invocation);
  // decode, then invoke when the operation is cap management (a data-plane one is only decoded).
  [[nodiscard]] Result<Performed, CapError> decode_and_invoke(ServiceId caller, Slot slot, Operation op,
                                                              const Args& args = NoArgs{});

  // ---- Kernel side ----

  // Makes every policy slot hold exactly the table's rights for `mode` (Fig. 1 transitions, §III "SEI":
  // e.g. the Network caps go in RB). Validates first, then revokes + deletes every slot whose content
  // differs and mints the new caps from the originals. Does not judge whether the transition is allowed
  // by Fig. 1: that is the mode manager's job (fault handling may jump to SC from anywhere).
  [[nodiscard]] Result<ModeChange, ModeError> apply_mode(SrMode mode);
  [[nodiscard]] SrMode mode() const { return mode_; }
  // The kernel clock, stamped on denials (docs/design.md §6: the kernel owns time).
  void set_time(Nanos now) { now_ = now; }

  // ---- Read access ----

  [[nodiscard]] Result<BootInfo, CapError> boot_info(ServiceId service) const;
  [[nodiscard]] std::optional<Capability> lookup(CapRef at) const;
  [[nodiscard]] std::optional<CapRef> parent_of(CapRef at) const;
  [[nodiscard]] std::vector<CapRef> children_of(CapRef at) const;
  [[nodiscard]] bool is_reserved(ServiceId service, Slot slot) const;
  [[nodiscard]] CapState snapshot() const;
  [[nodiscard]] std::size_t service_count() const { return services_; }
  [[nodiscard]] std::size_t object_count() const { return objects_.size(); }
  [[nodiscard]] std::size_t cspace_slots() const { return slots_per_space_; }
  [[nodiscard]] const AuditLog& audit_log() const { return log_; }
  [[nodiscard]] const DenialCounters& denials() const { return counters_; }

 private:
  // A slot's content, 16 bytes: the hot path reads exactly one of these.
  struct Entry {
    ObjectId object;
    ObjectKind kind = ObjectKind::Topic;
    Rights rights;
    bool occupied = false;
    Badge badge;
  };
  // Derivation tree links by flat index (kNone = none); cold, kept apart from the entries.
  struct Links {
    std::uint32_t parent;
    std::uint32_t first_child;
    std::uint32_t next_sibling;
    std::uint32_t prev_sibling;
  };
  // A policy slot: where it is and what it holds in each mode.
  struct PolicySlot {
    std::uint32_t index;
    ServiceId service;
    Slot slot;
    ObjectId object;
    std::array<Rights, kModeCount> rights;
  };
  static constexpr std::uint32_t kNone = 0xFFFF'FFFFU;

  CapSystem(const ModeTable& table, const CapSystemConfig& config);

  [[nodiscard]] std::uint32_t index_of_slot(ServiceId service, Slot slot) const {
    return first_service_index_ + service.value() * slots_per_space_ + slot.value();
  }
  [[nodiscard]] CapRef ref_of(std::uint32_t index) const;
  [[nodiscard]] std::optional<std::uint32_t> index_of_ref(CapRef at) const;
  [[nodiscard]] static Capability cap_of(const Entry& e) {
    return {.object = e.object, .kind = e.kind, .rights = e.rights, .badge = e.badge};
  }

  [[nodiscard]] Result<Invocation, CapError> decode_management(Invocation inv, const Args& args) const;
  void fill(Invocation& inv, ServiceId caller, Slot slot, Operation op, const Entry& e) const;
  [[nodiscard]] Result<CapRef, CapError> resolve(ServiceId caller, const Destination& to) const;
  [[nodiscard]] std::unexpected<CapError> deny(ServiceId caller, Slot slot, Operation op, CapError error);

  void place(std::uint32_t parent, std::uint32_t index, const Capability& cap);
  [[nodiscard]] std::size_t delete_descendants(std::uint32_t index);
  [[nodiscard]] std::size_t delete_subtree(std::uint32_t root);
  void remove_leaf(std::uint32_t index);
  [[nodiscard]] bool matches(const PolicySlot& p, SrMode mode) const;

  std::uint32_t services_ = 0;
  std::uint32_t slots_per_space_ = 0;
  std::uint32_t first_service_index_ = 0;  // = number of objects: service CSpaces follow the originals
  std::vector<std::string> service_names_;
  std::vector<ObjectSpec> objects_;
  std::vector<Entry> entries_;  // [0, objects) originals; then services_ × slots_per_space_
  std::vector<Links> links_;
  std::vector<std::uint8_t> reserved_;   // by flat index: 1 = a policy slot
  std::vector<PolicySlot> policy_;       // by (service, slot)
  std::vector<std::uint32_t> plan_;      // apply_mode scratch, capacity = policy_.size()
  SrMode mode_ = SrMode::SC;
  Nanos now_{0};
  std::uint64_t version_ = 0;  // bumped on every change to any CSpace
  AuditLog log_;
  DenialCounters counters_;
};

}  // namespace rejuv::cap
