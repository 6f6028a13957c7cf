// Building CSpaces from a ModeTable, apply_mode (revoke + mint, docs/design.md §3) and boot info.
#include <gtest/gtest.h>

#include "cap_fixture.hpp"

namespace rejuv::cap {
namespace {

using namespace rejuv::cap::testing;

CapRef at(ServiceId s, std::uint32_t slot) { return CapRef{.space = s, .slot = Slot{slot}}; }

// Every policy slot holds exactly the table's rights for `mode`, as a direct unbadged child of the
// object's original; an empty-rights slot is empty.
void expect_slots_equal_table(const CapSystem& sys, const ModeTable& table, SrMode mode) {
  for (const SlotGrant& g : table.slots) {
    const CapRef where = at(g.service, g.slot.value());
    const Rights want = g.rights[index_of(mode)];
    const auto held = sys.lookup(where);
    if (want.empty()) {
      EXPECT_FALSE(held.has_value()) << "slot " << g.slot.value() << " in " << to_string(mode);
      continue;
    }
    ASSERT_TRUE(held.has_value()) << "slot " << g.slot.value() << " in " << to_string(mode);
    EXPECT_EQ(held->object, g.object);
    EXPECT_EQ(held->rights, want);
    EXPECT_EQ(held->badge, kNoBadge);
    EXPECT_EQ(sys.parent_of(where), (CapRef{.space = kKernelSpace, .slot = Slot{g.object.value()}}));
  }
}

TEST(ApplyMode, EveryMode_PolicySlotsEqualTable) {
  const ModeTable table = fixture_table();
  CapSystem sys = make_system();
  expect_slots_equal_table(sys, table, SrMode::SC);  // initial mode
  // The Fig. 1 cycle, twice, so every transition is taken from a non-initial state.
  for (int round = 0; round < 2; ++round) {
    for (const SrMode m : {SrMode::MC, SrMode::RB, SrMode::SC, SrMode::Update, SrMode::CP}) {
      const auto change = sys.apply_mode(m);
      ASSERT_TRUE(change.has_value());
      EXPECT_EQ(sys.mode(), m);
      expect_slots_equal_table(sys, table, m);
    }
  }
}

TEST(ApplyMode, McToRb_RevokesNetworkCap) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.apply_mode(SrMode::MC));
  ASSERT_TRUE(sys.decode(kExtLink, Slot{0}, Operation::NetSend).has_value());
  ASSERT_TRUE(sys.apply_mode(SrMode::RB));
  const auto send = sys.decode(kExtLink, Slot{0}, Operation::NetSend);  // §III: no network in the SEI
  ASSERT_FALSE(send.has_value());
  EXPECT_EQ(send.error(), CapError::EmptySlot);
}

TEST(ApplyMode, ChangedCap_RevokesCopiesInOtherCSpaces) {
  CapSystem sys = make_system();  // SC: sensors s2 setpoint is RWG
  const auto copy = sys.decode_and_invoke(kSensors, Slot{2}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}});
  ASSERT_TRUE(copy.has_value());
  ASSERT_TRUE(copy->placed.has_value());
  const auto change = sys.apply_mode(SrMode::Update);  // setpoint: none in Update
  ASSERT_TRUE(change.has_value());
  EXPECT_FALSE(sys.lookup(*copy->placed).has_value());
  EXPECT_FALSE(sys.lookup(at(kSensors, 2)).has_value());
}

TEST(ApplyMode, RightsReduced_CopyRevokedAndSlotReminted) {
  CapSystem sys = make_system();  // SC: setpoint RWG; MC: R
  const auto copy = sys.decode_and_invoke(kSensors, Slot{2}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{20}}});
  ASSERT_TRUE(copy.has_value());
  ASSERT_TRUE(sys.apply_mode(SrMode::MC));
  EXPECT_FALSE(sys.lookup(at(kSensors, 20)).has_value());
  const auto held = sys.lookup(at(kSensors, 2));
  ASSERT_TRUE(held.has_value());
  EXPECT_EQ(held->rights, rights_of("R"));
}

TEST(ApplyMode, UnchangedCap_KeepsItsCopies) {
  CapSystem sys = make_system();  // sensors s0 imu RWG in every mode
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{20}}}));
  ASSERT_TRUE(sys.apply_mode(SrMode::MC));
  EXPECT_TRUE(sys.lookup(at(kSensors, 20)).has_value());
}

TEST(ApplyMode, Counts_SlotsChangedDeletedAndMinted) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{2}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{20}}}));
  const auto change = sys.apply_mode(SrMode::MC);
  ASSERT_TRUE(change.has_value());
  EXPECT_EQ(change->from, SrMode::SC);
  EXPECT_EQ(change->to, SrMode::MC);
  // SC → MC: sensors s1 (mint), s2 (RWG → R), ext_link s0 (mint), checkpoint_p s0, s1 (delete).
  EXPECT_EQ(change->slots_changed, 5U);
  EXPECT_EQ(change->deleted, 4U);  // s2, its copy, ckpt, limits
  EXPECT_EQ(change->minted, 3U);
}

TEST(ApplyMode, SameModeAgain_ChangesNothing) {
  CapSystem sys = make_system();
  const CapState before = sys.snapshot();
  const auto change = sys.apply_mode(SrMode::SC);
  ASSERT_TRUE(change.has_value());
  EXPECT_EQ(change->slots_changed, 0U);
  EXPECT_EQ(sys.snapshot(), before);
}

TEST(ApplyMode, UnknownMode_RefusedAndNothingChanges) {
  CapSystem sys = make_system();
  const CapState before = sys.snapshot();
  const auto change = sys.apply_mode(static_cast<SrMode>(kModeCount));
  ASSERT_FALSE(change.has_value());
  EXPECT_EQ(change.error(), ModeError::UnknownMode);
  EXPECT_EQ(sys.snapshot(), before);
  EXPECT_EQ(sys.mode(), SrMode::SC);
}

TEST(ApplyMode, DenialsRecordTheModeInForce) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.apply_mode(SrMode::CP));
  ASSERT_FALSE(sys.decode(kExtLink, Slot{0}, Operation::NetReceive));
  EXPECT_EQ(sys.audit_log().newest().mode, SrMode::CP);
}

TEST(Create, InitialMode_FromConfig) {
  const CapSystem sys = make_system({.initial_mode = SrMode::MC});
  EXPECT_EQ(sys.mode(), SrMode::MC);
  expect_slots_equal_table(sys, fixture_table(), SrMode::MC);
}

TEST(Create, PolicySlots_AreReservedOthersAreNot) {
  const CapSystem sys = make_system();
  EXPECT_TRUE(sys.is_reserved(kSensors, Slot{1}));
  EXPECT_TRUE(sys.is_reserved(kCheckpointP, Slot{3}));
  EXPECT_FALSE(sys.is_reserved(kCheckpointP, Slot{4}));
  EXPECT_FALSE(sys.is_reserved(ServiceId{9}, Slot{0}));
}

// ---- table validation: one test per TableError kind ----

void expect_table_error(const ModeTable& t, TableError::Kind want, const CapSystemConfig& config = {}) {
  const auto sys = CapSystem::create(t, config);
  ASSERT_FALSE(sys.has_value());
  EXPECT_EQ(sys.error().kind, want) << sys.error().to_string();
  EXPECT_FALSE(sys.error().message.empty());
}

TEST(CreateTableError, BadConfig_ZeroSlots) {
  expect_table_error(fixture_table(), TableError::Kind::BadConfig, {.cspace_slots = 0});
}

TEST(CreateTableError, BadConfig_ZeroAuditCapacity) {
  expect_table_error(fixture_table(), TableError::Kind::BadConfig, {.audit_capacity = 0});
}

TEST(CreateTableError, DuplicateName_TwoServicesSameName) {
  ModeTable t = fixture_table();
  t.services[1] = "sensors";
  expect_table_error(t, TableError::Kind::DuplicateName);
}

TEST(CreateTableError, DuplicateName_TwoObjectsSameName) {
  ModeTable t = fixture_table();
  t.objects[1].name = "imu";
  expect_table_error(t, TableError::Kind::DuplicateName);
}

TEST(CreateTableError, ObjectIdMismatch_IdNotIndex) {
  ModeTable t = fixture_table();
  t.objects[2].id = ObjectId{5};
  expect_table_error(t, TableError::Kind::ObjectIdMismatch);
}

TEST(CreateTableError, UnknownService_GrantToMissingService) {
  ModeTable t = fixture_table();
  t.slots[0].service = ServiceId{3};
  expect_table_error(t, TableError::Kind::UnknownService);
}

TEST(CreateTableError, UnknownObject_GrantOfMissingObject) {
  ModeTable t = fixture_table();
  t.slots[0].object = ObjectId{7};
  expect_table_error(t, TableError::Kind::UnknownObject);
}

TEST(CreateTableError, SlotOutOfRange_SlotBeyondCSpace) {
  ModeTable t = fixture_table();
  t.slots[0].slot = Slot{8};
  expect_table_error(t, TableError::Kind::SlotOutOfRange, {.cspace_slots = 8});
}

TEST(CreateTableError, DuplicateSlot_TwoObjectsOneSlot) {
  ModeTable t = fixture_table();
  t.slots[1].slot = Slot{0};
  expect_table_error(t, TableError::Kind::DuplicateSlot);
}

TEST(CreateTableError, DuplicateGrant_OneObjectTwoSlots) {
  ModeTable t = fixture_table();
  t.slots[1].object = kImu;
  expect_table_error(t, TableError::Kind::DuplicateGrant);
}

// ---- boot info ----

TEST(BootInfo, ListsEveryCapWithSlotKindAndPerModeRights) {
  const CapSystem sys = make_system();
  const auto info = sys.boot_info(kCheckpointP);
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->name, "checkpoint_p");
  EXPECT_EQ(info->cspace_slots, 256U);
  ASSERT_EQ(info->caps.size(), 4U);
  const auto ckpt = info->find("ckpt");
  ASSERT_TRUE(ckpt.has_value());
  EXPECT_EQ(ckpt->slot, Slot{0});
  EXPECT_EQ(ckpt->object, kCkpt);
  EXPECT_EQ(ckpt->kind, ObjectKind::Checkpoint);
  EXPECT_TRUE(ckpt->rights_in(SrMode::MC).empty());  // §IV-C: checkpoint calls disabled in MC
  EXPECT_EQ(ckpt->rights_in(SrMode::SC), rights_of("W"));
  const auto mode = info->find("mode");
  ASSERT_TRUE(mode.has_value());
  EXPECT_EQ(mode->slot, Slot{3});
}

TEST(BootInfo, UnknownService_NoSuchService) {
  const CapSystem sys = make_system();
  const auto info = sys.boot_info(ServiceId{3});
  ASSERT_FALSE(info.has_value());
  EXPECT_EQ(info.error(), CapError::NoSuchService);
}

}  // namespace
}  // namespace rejuv::cap
