#include "rejuv/cap/cap_system.hpp"

#include <algorithm>
#include <limits>
#include <set>
#include <utility>

namespace rejuv::cap {

namespace {

[[nodiscard]] TableError table_error(TableError::Kind kind, std::string message) {
  return TableError{.kind = kind, .message = std::move(message)};
}

[[nodiscard]] bool valid_mode(SrMode mode) { return index_of(mode) < kModeCount; }

// requirement() as a table indexed by the operation value: one load instead of a jump table on the hot path.
constexpr auto kRequirements = [] {
  std::array<Requirement, kOperationCount> table{};
  for (const Operation op : kAllOperations) {
    table[static_cast<std::size_t>(op)] = requirement(op);
  }
  return table;
}();

}  // namespace

std::string_view to_string(ModeError error) {
  switch (error) {
    case ModeError::UnknownMode: return "UnknownMode";
  }
  return "?";
}

std::string_view to_string(TableError::Kind kind) {
  switch (kind) {
    case TableError::Kind::BadConfig: return "BadConfig";
    case TableError::Kind::DuplicateName: return "DuplicateName";
    case TableError::Kind::ObjectIdMismatch: return "ObjectIdMismatch";
    case TableError::Kind::UnknownService: return "UnknownService";
    case TableError::Kind::UnknownObject: return "UnknownObject";
    case TableError::Kind::SlotOutOfRange: return "SlotOutOfRange";
    case TableError::Kind::DuplicateSlot: return "DuplicateSlot";
    case TableError::Kind::DuplicateGrant: return "DuplicateGrant";
  }
  return "?";
}

std::string TableError::to_string() const {
  return std::string(cap::to_string(kind)) + ": " + message;
}

Result<BootCap, CapError> BootInfo::find(std::string_view object_name) const {
  for (const BootCap& c : caps) {
    if (c.name == object_name) {
      return c;
    }
  }
  return fail(CapError::NoSuchObject);
}

// ---- Creation: validate the whole table, then build (nothing half-built escapes) ----

Result<CapSystem, TableError> CapSystem::create(const ModeTable& table, const CapSystemConfig& config) {
  using K = TableError::Kind;
  if (config.cspace_slots == 0 || config.audit_capacity == 0) {
    return fail(table_error(K::BadConfig, "cspace_slots and audit_capacity must be at least 1"));
  }
  // Flat indices are u32 with one value kept for kNone.
  const std::uint64_t flat = table.objects.size() + std::uint64_t{table.services.size()} * config.cspace_slots;
  if (flat >= std::numeric_limits<std::uint32_t>::max() || table.services.size() >= kKernelSpace.value()) {
    return fail(table_error(K::BadConfig, "too many slots: " + std::to_string(flat)));
  }
  std::set<std::string_view> names;
  for (const std::string& s : table.services) {
    if (!names.insert(s).second) {
      return fail(table_error(K::DuplicateName, "service '" + s + "' appears twice"));
    }
  }
  names.clear();
  for (std::size_t i = 0; i < table.objects.size(); ++i) {
    const ObjectSpec& o = table.objects[i];
    if (o.id.value() != i) {
      return fail(table_error(K::ObjectIdMismatch, "object '" + o.name + "' at index " + std::to_string(i) +
                                                       " has id " + std::to_string(o.id.value())));
    }
    if (!names.insert(o.name).second) {
      return fail(table_error(K::DuplicateName, "object '" + o.name + "' appears twice"));
    }
  }
  std::set<std::pair<std::uint32_t, std::uint32_t>> slots_taken;
  std::set<std::pair<std::uint32_t, std::uint32_t>> objects_granted;
  for (const SlotGrant& g : table.slots) {
    if (g.service.value() >= table.services.size()) {
      return fail(table_error(K::UnknownService, "grant names service #" + std::to_string(g.service.value())));
    }
    const std::string& service = table.services[g.service.value()];
    if (g.object.value() >= table.objects.size()) {
      return fail(table_error(K::UnknownObject, "grant to '" + service + "' names object #" +
                                                    std::to_string(g.object.value())));
    }
    const std::string& object = table.objects[g.object.value()].name;
    if (g.slot.value() >= config.cspace_slots) {
      return fail(table_error(K::SlotOutOfRange, "'" + service + "' slot " + std::to_string(g.slot.value()) +
                                                     " for '" + object + "' ≥ CSpace size " +
                                                     std::to_string(config.cspace_slots)));
    }
    if (!slots_taken.emplace(g.service.value(), g.slot.value()).second) {
      return fail(table_error(K::DuplicateSlot, "'" + service + "' slot " + std::to_string(g.slot.value()) +
                                                    " is granted twice"));
    }
    if (!objects_granted.emplace(g.service.value(), g.object.value()).second) {
      return fail(table_error(K::DuplicateGrant, "'" + service + "' has two slots for '" + object + "'"));
    }
  }
  if (!valid_mode(config.initial_mode)) {
    return fail(table_error(K::BadConfig, "initial_mode is not a mode"));
  }
  return CapSystem(table, config);
}

CapSystem::CapSystem(const ModeTable& table, const CapSystemConfig& config)
    : services_(static_cast<std::uint32_t>(table.services.size())),
      slots_per_space_(static_cast<std::uint32_t>(config.cspace_slots)),
      first_service_index_(static_cast<std::uint32_t>(table.objects.size())),
      service_names_(table.services),
      objects_(table.objects),
      log_(config.audit_capacity),
      counters_(table.services.size()) {
  const std::size_t flat = objects_.size() + std::size_t{services_} * slots_per_space_;
  entries_.resize(flat);
  links_.assign(flat, Links{.parent = kNone, .first_child = kNone, .next_sibling = kNone, .prev_sibling = kNone});
  reserved_.assign(flat, 0);
  // The kernel creates every object and keeps its original with all rights (docs/design.md §3).
  for (const ObjectSpec& o : objects_) {
    entries_[o.id.value()] =
        Entry{.object = o.id, .kind = o.kind, .rights = Rights::all(), .occupied = true, .badge = kNoBadge};
  }
  policy_.reserve(table.slots.size());
  for (const SlotGrant& g : table.slots) {
    const std::uint32_t index = index_of_slot(g.service, g.slot);
    reserved_[index] = 1;
    policy_.push_back(
        PolicySlot{.index = index, .service = g.service, .slot = g.slot, .object = g.object, .rights = g.rights});
  }
  std::ranges::sort(policy_, {}, &PolicySlot::index);
  plan_.reserve(policy_.size());
  // Every slot starts empty, so applying the initial mode mints exactly the table's caps.
  mode_ = config.initial_mode;
  const auto initial = apply_mode(config.initial_mode);
  REJUV_ASSERT(initial.has_value(), "initial mode validated by create()");
}

// ---- Decode then invoke (seL4): every check before any change ----

Result<Invocation, CapError> CapSystem::decode(ServiceId caller, Slot slot, Operation op, const Args& args) {
  if (caller.value() >= services_) [[unlikely]] {
    return deny(caller, slot, op, CapError::NoSuchService);
  }
  if (slot.value() >= slots_per_space_) [[unlikely]] {
    return deny(caller, slot, op, CapError::SlotOutOfRange);
  }
  // The caller's identity selects its CSpace; the slot indexes only inside it (docs/design.md §2).
  const Entry& e = entries_[index_of_slot(caller, slot)];
  if (!e.occupied) [[unlikely]] {
    return deny(caller, slot, op, CapError::EmptySlot);
  }
  if (static_cast<std::size_t>(op) >= kOperationCount) [[unlikely]] {
    return deny(caller, slot, op, CapError::BadArgument);
  }
  const Requirement& need = kRequirements[static_cast<std::size_t>(op)];
  if (!need.any_kind && e.kind != need.kind) [[unlikely]] {
    return deny(caller, slot, op, CapError::WrongObject);
  }
  if (!e.rights.contains(need.rights)) [[unlikely]] {
    return deny(caller, slot, op, CapError::InsufficientRights);
  }
  if (!is_cap_management(op)) [[likely]] {
    if (!std::holds_alternative<NoArgs>(args)) [[unlikely]] {
      return deny(caller, slot, op, CapError::BadArgument);
    }
    // Built in place in the result: no copy of the token on the broker's hot path.
    Result<Invocation, CapError> out(std::in_place, InvocationKey{});
    fill(*out, caller, slot, op, e);
    return out;
  }
  Invocation inv{InvocationKey{}};
  fill(inv, caller, slot, op, e);
  auto managed = decode_management(inv, args);
  if (!managed) {
    return deny(caller, slot, op, managed.error());
  }
  return managed;
}

void CapSystem::fill(Invocation& inv, ServiceId caller, Slot slot, Operation op, const Entry& e) const {
  inv.cap_ = cap_of(e);
  inv.version_ = version_;
  inv.caller_ = caller;
  inv.slot_ = slot;
  inv.operation_ = op;
}

Result<Invocation, CapError> CapSystem::decode_management(Invocation inv, const Args& args) const {
  const Capability& source = inv.cap_;
  const std::optional<CapManagement> op = management_of(inv.operation_);
  REJUV_ASSERT(op.has_value(), "decode_management called for a data-plane operation");
  switch (*op) {
    case CapManagement::Copy: {
      const auto* copy = std::get_if<CopyArgs>(&args);
      if (copy == nullptr) {
        return fail(CapError::BadArgument);
      }
      // seL4 Copy: the derived cap holds parent.rights & mask, never more (docs/design.md §3).
      const Rights rights = source.rights & copy->mask;
      if (rights.empty()) {
        return fail(CapError::BadArgument);  // a cap with no right is only clutter in a CSpace
      }
      auto to = resolve(inv.caller_, copy->to);
      if (!to) {
        return fail(to.error());
      }
      inv.destination_ = *to;
      inv.derived_rights_ = rights;
      inv.derived_badge_ = source.badge;
      return inv;
    }
    case CapManagement::Mint: {
      const auto* mint = std::get_if<MintArgs>(&args);
      if (mint == nullptr) {
        return fail(CapError::BadArgument);
      }
      // seL4 Mint: a badge is set once, on an unbadged cap; 0 would mean "unbadged", i.e. a Copy.
      if (mint->badge == kNoBadge || source.badge != kNoBadge) {
        return fail(CapError::BadArgument);
      }
      const Rights rights = source.rights & mint->mask;
      if (rights.empty()) {
        return fail(CapError::BadArgument);
      }
      auto to = resolve(inv.caller_, mint->to);
      if (!to) {
        return fail(to.error());
      }
      inv.destination_ = *to;
      inv.derived_rights_ = rights;
      inv.derived_badge_ = mint->badge;
      return inv;
    }
    case CapManagement::Revoke:
    case CapManagement::Delete:
      if (!std::holds_alternative<NoArgs>(args)) {
        return fail(CapError::BadArgument);
      }
      return inv;
  }
  return fail(CapError::BadArgument);
}

Result<CapRef, CapError> CapSystem::resolve(ServiceId caller, const Destination& to) const {
  if (const auto* own = std::get_if<OwnSlot>(&to)) {
    if (own->slot.value() >= slots_per_space_) {
      return fail(CapError::SlotOutOfRange);
    }
    const std::uint32_t index = index_of_slot(caller, own->slot);
    if (reserved_[index] != 0) {
      return fail(CapError::ReservedSlot);  // only apply_mode writes policy slots
    }
    if (entries_[index].occupied) {
      return fail(CapError::SlotOccupied);
    }
    return CapRef{.space = caller, .slot = own->slot};
  }
  const ServiceId receiver = std::get<Transfer>(to).to;
  if (receiver.value() >= services_) {
    return fail(CapError::NoSuchService);
  }
  // The kernel picks the slot, so the caller learns nothing about and cannot aim at the receiver's CSpace.
  for (std::uint32_t s = 0; s < slots_per_space_; ++s) {
    const std::uint32_t index = index_of_slot(receiver, Slot{s});
    if (reserved_[index] == 0 && !entries_[index].occupied) {
      return CapRef{.space = receiver, .slot = Slot{s}};
    }
  }
  return fail(CapError::CSpaceFull);
}

// Cold: kept out of line so that decode's success path stays short.
[[gnu::cold, gnu::noinline]] std::unexpected<CapError> CapSystem::deny(ServiceId caller, Slot slot, Operation op,
                                                                       CapError error) {
  counters_.record(caller, error, op);
  log_.push(Denial{.at = now_, .service = caller, .slot = slot, .operation = op, .error = error, .mode = mode_});
  return std::unexpected<CapError>(error);
}

Performed CapSystem::invoke(const Invocation& inv) {
  REJUV_ASSERT(inv.version_ == version_, "stale Invocation: a CSpace changed since it was decoded");
  const std::uint32_t source = index_of_slot(inv.caller_, inv.slot_);
  REJUV_ASSERT(entries_[source].occupied && cap_of(entries_[source]) == inv.cap_, "Invocation source moved");
  const std::optional<CapManagement> op = management_of(inv.operation_);
  REJUV_ASSERT(op.has_value(), "invoke of a data-plane Invocation: its component carries it out");
  Performed done;
  switch (*op) {
    case CapManagement::Copy:
    case CapManagement::Mint: {
      const std::uint32_t dest = index_of_slot(inv.destination_.space, inv.destination_.slot);
      place(source, dest, inv.derived());
      done.placed = inv.destination_;
      break;
    }
    case CapManagement::Revoke: done.deleted = delete_descendants(source); break;
    case CapManagement::Delete: done.deleted = delete_subtree(source); break;
  }
  ++version_;
  return done;
}

Result<Performed, CapError> CapSystem::decode_and_invoke(ServiceId caller, Slot slot, Operation op,
                                                         const Args& args) {
  auto inv = decode(caller, slot, op, args);
  if (!inv) {
    return fail(inv.error());
  }
  if (!is_cap_management(op)) {
    return Performed{};
  }
  return invoke(*inv);
}

// ---- Derivation tree ----

void CapSystem::place(std::uint32_t parent, std::uint32_t index, const Capability& cap) {
  REJUV_ASSERT(!entries_[index].occupied, "placing a cap into an occupied slot");
  REJUV_ASSERT(entries_[parent].occupied, "placing a cap under an empty parent");
  entries_[index] = Entry{.object = cap.object, .kind = cap.kind, .rights = cap.rights, .occupied = true, .badge = cap.badge};
  Links& l = links_[index];
  l.parent = parent;
  l.prev_sibling = kNone;
  l.first_child = kNone;
  l.next_sibling = links_[parent].first_child;
  if (l.next_sibling != kNone) {
    links_[l.next_sibling].prev_sibling = index;
  }
  links_[parent].first_child = index;
}

void CapSystem::remove_leaf(std::uint32_t index) {
  Links& l = links_[index];
  REJUV_ASSERT(l.first_child == kNone, "removing a cap that still has children");
  if (l.prev_sibling != kNone) {
    links_[l.prev_sibling].next_sibling = l.next_sibling;
  } else if (l.parent != kNone) {
    links_[l.parent].first_child = l.next_sibling;
  }
  if (l.next_sibling != kNone) {
    links_[l.next_sibling].prev_sibling = l.prev_sibling;
  }
  l = Links{.parent = kNone, .first_child = kNone, .next_sibling = kNone, .prev_sibling = kNone};
  entries_[index] = Entry{};
}

// Iterative post-order walk (no recursion: a chain of copies can be as deep as there are slots).
std::size_t CapSystem::delete_subtree(std::uint32_t root) {
  REJUV_ASSERT(root >= objects_.size(), "the kernel's originals are never deleted");
  std::size_t deleted = 0;
  std::uint32_t at = root;
  for (;;) {
    while (links_[at].first_child != kNone) {
      at = links_[at].first_child;
    }
    const std::uint32_t up = links_[at].parent;
    const bool last = at == root;
    remove_leaf(at);
    ++deleted;
    if (last) {
      return deleted;
    }
    at = up;
  }
}

std::size_t CapSystem::delete_descendants(std::uint32_t index) {
  std::size_t deleted = 0;
  while (links_[index].first_child != kNone) {
    deleted += delete_subtree(links_[index].first_child);
  }
  return deleted;
}

// ---- Mode transitions ----

bool CapSystem::matches(const PolicySlot& p, SrMode mode) const {
  const Rights want = p.rights[index_of(mode)];
  const Entry& e = entries_[p.index];
  if (want.empty()) {
    return !e.occupied;
  }
  return e.occupied && e.object == p.object && e.rights == want && e.badge == kNoBadge &&
         links_[p.index].parent == p.object.value();
}

Result<ModeChange, ModeError> CapSystem::apply_mode(SrMode mode) {
  if (!valid_mode(mode)) {
    return fail(ModeError::UnknownMode);
  }
  // Phase 1, validate and plan: which policy slots differ from the table (no allocation: plan_ is
  // reserved for every policy slot). Nothing has changed yet.
  plan_.clear();
  for (std::uint32_t i = 0; i < policy_.size(); ++i) {
    if (!matches(policy_[i], mode)) {
      plan_.push_back(i);
    }
  }
  for (const std::uint32_t i : plan_) {
    const PolicySlot& p = policy_[i];
    REJUV_ASSERT(reserved_[p.index] != 0, "policy slot not reserved");
    REJUV_ASSERT(entries_[p.object.value()].occupied, "original of a policy object missing");
  }
  // Phase 2, revoke + delete every changed slot (its copies go with it, docs/design.md §3), then mint.
  ModeChange change{.from = mode_, .to = mode, .slots_changed = plan_.size()};
  for (const std::uint32_t i : plan_) {
    if (entries_[policy_[i].index].occupied) {
      change.deleted += delete_subtree(policy_[i].index);
    }
  }
  for (const std::uint32_t i : plan_) {
    const PolicySlot& p = policy_[i];
    const Rights want = p.rights[index_of(mode)];
    if (!want.empty()) {
      const Entry& original = entries_[p.object.value()];
      place(p.object.value(), p.index,
            Capability{.object = p.object, .kind = original.kind, .rights = want, .badge = kNoBadge});
      ++change.minted;
    }
  }
  mode_ = mode;
  ++version_;
  return change;
}

// ---- Read access ----

CapRef CapSystem::ref_of(std::uint32_t index) const {
  if (index < objects_.size()) {
    return CapRef{.space = kKernelSpace, .slot = Slot{index}};
  }
  const std::uint32_t rel = index - static_cast<std::uint32_t>(objects_.size());
  return CapRef{.space = ServiceId{rel / slots_per_space_}, .slot = Slot{rel % slots_per_space_}};
}

std::optional<std::uint32_t> CapSystem::index_of_ref(CapRef at) const {
  if (at.is_original()) {
    if (at.slot.value() >= objects_.size()) {
      return std::nullopt;
    }
    return at.slot.value();
  }
  if (at.space.value() >= services_ || at.slot.value() >= slots_per_space_) {
    return std::nullopt;
  }
  return index_of_slot(at.space, at.slot);
}

Result<BootInfo, CapError> CapSystem::boot_info(ServiceId service) const {
  if (service.value() >= services_) {
    return fail(CapError::NoSuchService);
  }
  BootInfo info{.service = service, .name = service_names_[service.value()], .cspace_slots = slots_per_space_, .caps = {}};
  for (const PolicySlot& p : policy_) {  // sorted by flat index, so by slot within a service
    if (p.service == service) {
      const ObjectSpec& o = objects_[p.object.value()];
      info.caps.push_back(BootCap{.name = o.name, .slot = p.slot, .object = o.id, .kind = o.kind, .rights = p.rights});
    }
  }
  return info;
}

std::optional<Capability> CapSystem::lookup(CapRef at) const {
  const auto index = index_of_ref(at);
  if (!index || !entries_[*index].occupied) {
    return std::nullopt;
  }
  return cap_of(entries_[*index]);
}

std::optional<CapRef> CapSystem::parent_of(CapRef at) const {
  const auto index = index_of_ref(at);
  if (!index || !entries_[*index].occupied || links_[*index].parent == kNone) {
    return std::nullopt;
  }
  return ref_of(links_[*index].parent);
}

std::vector<CapRef> CapSystem::children_of(CapRef at) const {
  std::vector<CapRef> out;
  const auto index = index_of_ref(at);
  if (!index) {
    return out;
  }
  for (std::uint32_t c = links_[*index].first_child; c != kNone; c = links_[c].next_sibling) {
    out.push_back(ref_of(c));
  }
  return out;
}

bool CapSystem::is_reserved(ServiceId service, Slot slot) const {
  const auto index = index_of_ref(CapRef{.space = service, .slot = slot});
  return index && !CapRef{.space = service, .slot = slot}.is_original() && reserved_[*index] != 0;
}

CapState CapSystem::snapshot() const {
  CapState state{.mode = mode_, .caps = {}};
  for (std::uint32_t i = 0; i < entries_.size(); ++i) {
    if (!entries_[i].occupied) {
      continue;
    }
    std::optional<CapRef> parent;
    if (links_[i].parent != kNone) {
      parent = ref_of(links_[i].parent);
    }
    state.caps.push_back(CapRecord{.at = ref_of(i), .cap = cap_of(entries_[i]), .parent = parent});
  }
  return state;
}

}  // namespace rejuv::cap
