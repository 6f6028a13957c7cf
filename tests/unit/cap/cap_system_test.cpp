// Decode-then-invoke, derivation (Copy/Mint never gain rights), Revoke/Delete, isolation between CSpaces
// and the denial record (docs/design.md §3).
#include <gtest/gtest.h>

#include <algorithm>

#include "cap_fixture.hpp"

namespace rejuv::cap {
namespace {

using namespace rejuv::cap::testing;

CapRef at(ServiceId s, std::uint32_t slot) { return CapRef{.space = s, .slot = Slot{slot}}; }
CapRef original(ObjectId o) { return CapRef{.space = kKernelSpace, .slot = Slot{o.value()}}; }

// ---- decode ----

TEST(Decode, PublishOnWritableTopic_ReturnsValidatedToken) {
  CapSystem sys = make_system();
  const auto inv = sys.decode(kSensors, Slot{0}, Operation::Publish);
  ASSERT_TRUE(inv.has_value());
  EXPECT_EQ(inv->caller(), kSensors);
  EXPECT_EQ(inv->slot(), Slot{0});
  EXPECT_EQ(inv->object(), kImu);
  EXPECT_EQ(inv->kind(), ObjectKind::Topic);
  EXPECT_EQ(inv->badge(), kNoBadge);
  EXPECT_EQ(inv->operation(), Operation::Publish);
  EXPECT_EQ(sys.denials().total(), 0U);
}

// Every operation against a cap of every kind, with every single right and with all rights: decode
// succeeds exactly when requirement(op) holds (docs/design.md §3 kind + right table).
TEST(Decode, EveryOperationKindAndRight_SucceedsIffRequirementHolds) {
  ModeTable t;
  t.services = {"svc"};
  std::uint32_t slot = 0;
  for (const ObjectKind kind : kAllObjectKinds) {
    const auto id = ObjectId{static_cast<std::uint32_t>(t.objects.size())};
    t.objects.push_back({.id = id, .kind = kind, .name = std::string(to_string(kind))});
    // Grants on one object must share a slot, so give each rights set its own object.
    for (const Rights r : {Rights{Right::Read}, Rights{Right::Write}, Rights{Right::Grant}, Rights::all()}) {
      const auto obj = ObjectId{static_cast<std::uint32_t>(t.objects.size())};
      t.objects.push_back({.id = obj, .kind = kind, .name = std::string(to_string(kind)) + r.to_string()});
      t.slots.push_back({.service = ServiceId{0}, .slot = Slot{slot++}, .object = obj, .rights = always(r)});
    }
  }
  auto sys = CapSystem::create(t);
  ASSERT_TRUE(sys.has_value());
  for (const SlotGrant& g : t.slots) {
    const ObjectKind kind = t.objects[g.object.value()].kind;
    const Rights held = g.rights[0];
    for (const Operation op : kAllOperations) {
      const Requirement need = requirement(op);
      const bool allowed = (need.any_kind || need.kind == kind) && held.contains(need.rights);
      Args args = NoArgs{};
      if (op == Operation::Copy) args = CopyArgs{.to = OwnSlot{Slot{200}}};
      if (op == Operation::Mint) args = MintArgs{.to = OwnSlot{Slot{200}}, .badge = Badge{1}};
      const auto inv = sys->decode(ServiceId{0}, g.slot, op, args);
      EXPECT_EQ(inv.has_value(), allowed) << to_string(op) << " on " << to_string(kind) << " " << held.to_string();
      if (!allowed && !inv.has_value()) {
        EXPECT_TRUE(inv.error() == CapError::WrongObject || inv.error() == CapError::InsufficientRights);
      }
    }
  }
}

TEST(Decode, Failures_LeaveCapStateUnchanged) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}}));
  const CapState before = sys.snapshot();
  const auto denials_before = sys.denials().total();
  // Given a battery of requests that each fail at a different check...
  EXPECT_FALSE(sys.decode_and_invoke(ServiceId{9}, Slot{0}, Operation::Delete));
  EXPECT_FALSE(sys.decode_and_invoke(kSensors, Slot{999}, Operation::Delete));
  EXPECT_FALSE(sys.decode_and_invoke(kSensors, Slot{40}, Operation::Revoke));
  EXPECT_FALSE(sys.decode_and_invoke(kExtLink, Slot{1}, Operation::Copy, CopyArgs{.to = Transfer{kSensors}}));
  EXPECT_FALSE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{2}}}));
  EXPECT_FALSE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Delete, CopyArgs{.to = OwnSlot{Slot{9}}}));
  EXPECT_FALSE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Mint, MintArgs{.to = OwnSlot{Slot{9}}}));
  EXPECT_FALSE(sys.decode_and_invoke(kCheckpointP, Slot{0}, Operation::LimitsWrite));
  // ...then no capability or derivation edge changed, and exactly one denial per request was recorded.
  EXPECT_EQ(sys.snapshot(), before);
  EXPECT_EQ(sys.denials().total(), denials_before + 8);
  EXPECT_EQ(sys.audit_log().size(), 8U);
}

TEST(Decode, Denial_RecordsServiceSlotOperationErrorModeAndTime) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.apply_mode(SrMode::MC));
  sys.set_time(Nanos{123'456});
  ASSERT_FALSE(sys.decode(kCheckpointP, Slot{0}, Operation::TimerArm));  // §III: no timer in MC
  const Denial& d = sys.audit_log().newest();
  EXPECT_EQ(d.seq, 0U);
  EXPECT_EQ(d.at, Nanos{123'456});
  EXPECT_EQ(d.service, kCheckpointP);
  EXPECT_EQ(d.slot, Slot{0});
  EXPECT_EQ(d.operation, Operation::TimerArm);
  EXPECT_EQ(d.error, CapError::EmptySlot);
  EXPECT_EQ(d.mode, SrMode::MC);
  EXPECT_EQ(sys.denials().at(kCheckpointP, CapError::EmptySlot, Operation::TimerArm), 1U);
}

TEST(Decode, Denials_CountedPerServiceErrorAndOperation) {
  CapSystem sys = make_system();
  ASSERT_FALSE(sys.decode(kSensors, Slot{7}, Operation::Publish));       // EmptySlot
  ASSERT_FALSE(sys.decode(kSensors, Slot{7}, Operation::Subscribe));     // EmptySlot
  ASSERT_FALSE(sys.decode(kExtLink, Slot{1}, Operation::Publish));       // InsufficientRights
  ASSERT_FALSE(sys.decode(ServiceId{50}, Slot{0}, Operation::Publish));  // NoSuchService
  const DenialCounters& c = sys.denials();
  EXPECT_EQ(c.total(), 4U);
  EXPECT_EQ(c.by_service(kSensors), 2U);
  EXPECT_EQ(c.by_service(kExtLink), 1U);
  EXPECT_EQ(c.by_service(kCheckpointP), 0U);
  EXPECT_EQ(c.unknown_service(), 1U);
  EXPECT_EQ(c.by_error(CapError::EmptySlot), 2U);
  EXPECT_EQ(c.by_error(CapError::InsufficientRights), 1U);
  EXPECT_EQ(c.by_operation(Operation::Publish), 3U);
  EXPECT_EQ(c.by_operation(Operation::Subscribe), 1U);
  EXPECT_EQ(c.at(kSensors, CapError::EmptySlot, Operation::Subscribe), 1U);
}

TEST(Decode, Success_IsNotCounted) {
  CapSystem sys = make_system();
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(sys.decode(kSensors, Slot{0}, Operation::Publish));
  }
  EXPECT_EQ(sys.denials().total(), 0U);
  EXPECT_TRUE(sys.audit_log().empty());
}

// ---- audit log ring ----

TEST(AuditLog, Overflow_KeepsNewestAndCountsOverwritten) {
  CapSystem sys = make_system({.audit_capacity = 4});
  for (std::uint32_t i = 0; i < 10; ++i) {
    ASSERT_FALSE(sys.decode(kSensors, Slot{100 + i}, Operation::Publish));
  }
  const AuditLog& log = sys.audit_log();
  EXPECT_EQ(log.size(), 4U);
  EXPECT_EQ(log.pushed(), 10U);
  EXPECT_EQ(log.overwritten(), 6U);
  for (std::size_t i = 0; i < log.size(); ++i) {
    EXPECT_EQ(log[i].seq, 6U + i);
    EXPECT_EQ(log[i].slot, Slot{106U + static_cast<std::uint32_t>(i)});
  }
  EXPECT_EQ(sys.denials().total(), 10U);  // counters never wrap with the ring
}

TEST(AuditLog, FirstIndexFrom_ResumesAfterLastSeenSeq) {
  AuditLog log(4);
  for (int i = 0; i < 6; ++i) {
    log.push(Denial{});
  }
  // Retained: seq 2..5.
  EXPECT_EQ(log.first_index_from(0), 0U);  // older than retained: start at the oldest
  EXPECT_EQ(log.first_index_from(2), 0U);
  EXPECT_EQ(log.first_index_from(4), 2U);
  EXPECT_EQ(log[log.first_index_from(4)].seq, 4U);
  EXPECT_EQ(log.first_index_from(6), 4U);  // nothing new
}

// ---- Copy / Mint ----

TEST(Copy, MaskWiderThanParent_NeverGainsRights) {
  CapSystem sys = make_system();
  // sensors s0 is RWG; copy it as RG, then copy the RG cap with a full mask.
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy,
                                    CopyArgs{.to = OwnSlot{Slot{10}}, .mask = rights_of("RG")}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{10}, Operation::Copy,
                                    CopyArgs{.to = OwnSlot{Slot{11}}, .mask = Rights::all()}));
  const auto grandchild = sys.lookup(at(kSensors, 11));
  ASSERT_TRUE(grandchild.has_value());
  EXPECT_EQ(grandchild->rights, rights_of("RG"));
  EXPECT_FALSE(sys.decode(kSensors, Slot{11}, Operation::Publish));  // no Write was ever passed down
}

TEST(Copy, KeepsObjectKindAndBadge_RecordsParent) {
  CapSystem sys = make_system();
  const auto done = sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy,
                                          CopyArgs{.to = OwnSlot{Slot{10}}, .mask = rights_of("R")});
  ASSERT_TRUE(done.has_value());
  ASSERT_TRUE(done->placed.has_value());
  EXPECT_EQ(*done->placed, at(kSensors, 10));
  const auto copy = sys.lookup(at(kSensors, 10));
  ASSERT_TRUE(copy.has_value());
  EXPECT_EQ(copy->object, kImu);
  EXPECT_EQ(copy->kind, ObjectKind::Topic);
  EXPECT_EQ(copy->badge, kNoBadge);
  EXPECT_EQ(sys.parent_of(at(kSensors, 10)), at(kSensors, 0));
  EXPECT_EQ(sys.parent_of(at(kSensors, 0)), original(kImu));
}

TEST(Mint, SetsBadgeAndMasksRights) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Mint,
                                    MintArgs{.to = OwnSlot{Slot{12}}, .mask = rights_of("W"), .badge = Badge{42}}));
  const auto inv = sys.decode(kSensors, Slot{12}, Operation::Publish);
  ASSERT_TRUE(inv.has_value());
  EXPECT_EQ(inv->badge(), Badge{42});
  EXPECT_EQ(inv->capability().rights, rights_of("W"));
}

TEST(Transfer, PlacesCapInReceiversLowestFreeUnreservedSlot) {
  CapSystem sys = make_system();
  const auto done = sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy,
                                          CopyArgs{.to = Transfer{kCheckpointP}, .mask = rights_of("R")});
  ASSERT_TRUE(done.has_value());
  // checkpoint_p's slots 0..3 are its policy slots.
  EXPECT_EQ(done->placed, at(kCheckpointP, 4));
  EXPECT_TRUE(sys.decode(kCheckpointP, Slot{4}, Operation::Subscribe).has_value());
  EXPECT_EQ(sys.parent_of(at(kCheckpointP, 4)), at(kSensors, 0));
}

// ---- Revoke / Delete ----

TEST(Revoke, RemovesEveryDescendantKeepsTheCap) {
  CapSystem sys = make_system();
  // s0 → s10 → (ext_link transfer) and s0 → s11.
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{10}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{11}}}));
  const auto done = sys.decode_and_invoke(kSensors, Slot{0}, Operation::Revoke);
  ASSERT_TRUE(done.has_value());
  EXPECT_EQ(done->deleted, 3U);
  EXPECT_TRUE(sys.lookup(at(kSensors, 0)).has_value());
  EXPECT_FALSE(sys.lookup(at(kSensors, 10)).has_value());
  EXPECT_FALSE(sys.lookup(at(kSensors, 11)).has_value());
  EXPECT_FALSE(sys.lookup(at(kExtLink, 2)).has_value());
  EXPECT_TRUE(sys.children_of(at(kSensors, 0)).empty());
}

TEST(Revoke, OnACopy_LeavesSiblingsAndAncestors) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{11}}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{10}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{12}}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{10}, Operation::Revoke));
  EXPECT_TRUE(sys.lookup(at(kSensors, 10)).has_value());
  EXPECT_TRUE(sys.lookup(at(kSensors, 11)).has_value());
  EXPECT_FALSE(sys.lookup(at(kSensors, 12)).has_value());
}

TEST(Delete, RemovesTheCapAndEveryDescendant) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{10}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}}));
  const auto done = sys.decode_and_invoke(kSensors, Slot{10}, Operation::Delete);
  ASSERT_TRUE(done.has_value());
  EXPECT_EQ(done->deleted, 2U);
  EXPECT_FALSE(sys.lookup(at(kSensors, 10)).has_value());
  EXPECT_FALSE(sys.lookup(at(kExtLink, 2)).has_value());
  EXPECT_TRUE(sys.lookup(at(kSensors, 0)).has_value());
  EXPECT_TRUE(sys.children_of(at(kSensors, 0)).empty());
}

TEST(Delete, FreedSlot_CanBeReused) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{10}, Operation::Delete));
  EXPECT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
}

TEST(Delete, PolicyCap_StaysEmptyUntilNextApplyMode) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kCheckpointP, Slot{2}, Operation::Delete));
  EXPECT_FALSE(sys.decode(kCheckpointP, Slot{2}, Operation::PersistentRead));
  ASSERT_TRUE(sys.apply_mode(sys.mode()));  // re-applying the mode in force repairs the slot
  EXPECT_TRUE(sys.decode(kCheckpointP, Slot{2}, Operation::PersistentRead).has_value());
}

TEST(Delete, OriginalsAreUnreachable_KernelKeepsThem) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Delete));
  const auto orig = sys.lookup(original(kImu));
  ASSERT_TRUE(orig.has_value());
  EXPECT_EQ(orig->rights, Rights::all());
}

// ---- isolation ----

TEST(Isolation, SameSlotIndex_NamesOnlyTheCallersOwnCap) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.apply_mode(SrMode::MC));
  // Slot 0 is imu in sensors' CSpace, net in ext_link's: each caller reaches only its own.
  const auto mine = sys.decode(kExtLink, Slot{0}, Operation::Publish);
  ASSERT_FALSE(mine.has_value());
  EXPECT_EQ(mine.error(), CapError::WrongObject);
  const auto net = sys.decode(kExtLink, Slot{0}, Operation::NetSend);
  ASSERT_TRUE(net.has_value());
  EXPECT_EQ(net->object(), kNet);
}

TEST(Isolation, DeleteInOneCSpace_LeavesSameSlotOfOthers) {
  CapSystem sys = make_system();
  const CapState before = sys.snapshot();
  ASSERT_TRUE(sys.decode_and_invoke(kExtLink, Slot{1}, Operation::Delete));
  const CapState after = sys.snapshot();
  // Exactly one record vanished, and it was ext_link's.
  ASSERT_EQ(after.caps.size() + 1, before.caps.size());
  for (const CapRecord& r : before.caps) {
    const bool kept = std::ranges::find(after.caps, r) != after.caps.end();
    EXPECT_EQ(kept, r.at != at(kExtLink, 1));
  }
}

TEST(Isolation, EveryDecode_ReflectsOnlyTheCallersSlot) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}}));
  for (std::uint32_t s = 0; s < sys.service_count(); ++s) {
    for (std::uint32_t slot = 0; slot < sys.cspace_slots(); ++slot) {
      const auto inv = sys.decode(ServiceId{s}, Slot{slot}, Operation::Revoke);
      const auto held = sys.lookup(at(ServiceId{s}, slot));
      ASSERT_EQ(inv.has_value(), held.has_value());
      if (held) {
        EXPECT_EQ(inv->capability(), *held);
      }
    }
  }
}

// ---- tokens ----

TEST(InvokeDeathTest, StaleToken_Aborts) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  CapSystem sys = make_system();
  const auto stale = sys.decode(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}});
  ASSERT_TRUE(stale.has_value());
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
  EXPECT_DEATH((void)sys.invoke(*stale), "stale Invocation");
}

TEST(InvokeDeathTest, DataPlaneToken_Aborts) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  CapSystem sys = make_system();
  const auto inv = sys.decode(kSensors, Slot{0}, Operation::Publish);
  ASSERT_TRUE(inv.has_value());
  EXPECT_DEATH((void)sys.invoke(*inv), "data-plane");
}

}  // namespace
}  // namespace rejuv::cap
