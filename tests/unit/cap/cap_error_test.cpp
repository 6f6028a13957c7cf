// One test per CapError code (sel4test style): each names the smallest request that must be refused
// with exactly that error, and checks the refusal was recorded.
#include <gtest/gtest.h>

#include <set>

#include "cap_fixture.hpp"

namespace rejuv::cap {
namespace {

using namespace rejuv::cap::testing;

// Asserts that `r` failed with `want` and that the denial is the newest audit entry.
template <class T>
void expect_denied(const CapSystem& sys, const Result<T, CapError>& r, CapError want) {
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error(), want) << to_string(r.error());
  ASSERT_FALSE(sys.audit_log().empty());
  EXPECT_EQ(sys.audit_log().newest().error, want);
  EXPECT_EQ(sys.denials().by_error(want), 1U);
}

TEST(CapError, NoSuchService_CallerOutsideGraph_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(ServiceId{3}, Slot{0}, Operation::Publish), CapError::NoSuchService);
  EXPECT_EQ(sys.denials().unknown_service(), 1U);
}

TEST(CapError, NoSuchService_KernelSpaceAsCaller_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kKernelSpace, Slot{0}, Operation::Publish), CapError::NoSuchService);
}

TEST(CapError, NoSuchService_TransferToUnknownReceiver_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = Transfer{ServiceId{7}}}),
                CapError::NoSuchService);
}

TEST(CapError, SlotOutOfRange_SlotEqualToCSpaceSize_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{256}, Operation::Publish), CapError::SlotOutOfRange);
}

TEST(CapError, SlotOutOfRange_CopyDestinationBeyondCSpace_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{1000}}}),
                CapError::SlotOutOfRange);
}

TEST(CapError, EmptySlot_NeverFilledSlot_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{5}, Operation::Publish), CapError::EmptySlot);
}

TEST(CapError, EmptySlot_PolicySlotEmptyInThisMode_Denied) {
  CapSystem sys = make_system();  // SC: the network slot of ext_link is empty (§III SEI)
  expect_denied(sys, sys.decode(kExtLink, Slot{0}, Operation::NetSend), CapError::EmptySlot);
}

TEST(CapError, SlotOccupied_CopyOntoHeldSlot_Denied) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}));
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{10}}}),
                CapError::SlotOccupied);
}

TEST(CapError, ReservedSlot_CopyIntoEmptyPolicySlot_Denied) {
  CapSystem sys = make_system();  // sensors slot 1 is reserved for `cell` and empty in SC
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{1}}}),
                CapError::ReservedSlot);
}

TEST(CapError, CSpaceFull_TransferToFullReceiver_Denied) {
  // 4 slots: ext_link's slots 0 and 1 are reserved, so two transfers fill it.
  CapSystem sys = make_system({.cspace_slots = 4});
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}}));
  }
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Copy, CopyArgs{.to = Transfer{kExtLink}}),
                CapError::CSpaceFull);
}

TEST(CapError, WrongObject_NetSendOnTopicCap_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::NetSend), CapError::WrongObject);
}

TEST(CapError, InsufficientRights_PublishOnReadOnlyTopic_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kExtLink, Slot{1}, Operation::Publish), CapError::InsufficientRights);
}

TEST(CapError, InsufficientRights_CopyWithoutGrant_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kExtLink, Slot{1}, Operation::Copy, CopyArgs{.to = OwnSlot{Slot{9}}}),
                CapError::InsufficientRights);
}

TEST(CapError, BadArgument_DataPlaneWithCopyArgs_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Publish, CopyArgs{.to = OwnSlot{Slot{9}}}),
                CapError::BadArgument);
}

TEST(CapError, BadArgument_CopyWithoutArgs_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys, sys.decode(kSensors, Slot{0}, Operation::Copy), CapError::BadArgument);
}

TEST(CapError, BadArgument_MaskLeavingNoRight_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys,
                sys.decode(kSensors, Slot{0}, Operation::Copy,
                           CopyArgs{.to = OwnSlot{Slot{9}}, .mask = Rights::none()}),
                CapError::BadArgument);
}

TEST(CapError, BadArgument_MintWithZeroBadge_Denied) {
  CapSystem sys = make_system();
  expect_denied(sys,
                sys.decode(kSensors, Slot{0}, Operation::Mint, MintArgs{.to = OwnSlot{Slot{9}}, .badge = kNoBadge}),
                CapError::BadArgument);
}

TEST(CapError, BadArgument_MintFromBadgedCap_Denied) {
  CapSystem sys = make_system();
  ASSERT_TRUE(sys.decode_and_invoke(kSensors, Slot{0}, Operation::Mint,
                                    MintArgs{.to = OwnSlot{Slot{9}}, .badge = Badge{5}}));
  expect_denied(sys,
                sys.decode(kSensors, Slot{9}, Operation::Mint, MintArgs{.to = OwnSlot{Slot{10}}, .badge = Badge{6}}),
                CapError::BadArgument);
}

TEST(CapError, BadArgument_OperationValueOutOfRange_Denied) {
  CapSystem sys = make_system();
  const auto bogus = static_cast<Operation>(kOperationCount);  // what a bad cast upstream would give
  expect_denied(sys, sys.decode(kSensors, Slot{0}, bogus), CapError::BadArgument);
  EXPECT_EQ(sys.denials().invalid_operation(), 1U);
}

TEST(CapError, NoSuchObject_BootInfoLookupOfUngrantedName_Refused) {
  const CapSystem sys = make_system();
  const auto info = sys.boot_info(kExtLink);
  ASSERT_TRUE(info.has_value());
  const auto cap = info->find("limits");  // exists, but ext_link may never hold it
  ASSERT_FALSE(cap.has_value());
  EXPECT_EQ(cap.error(), CapError::NoSuchObject);
  EXPECT_EQ(info->find("nonexistent").error(), CapError::NoSuchObject);
}

TEST(CapError, ToString_EveryCode_DistinctAndNamed) {
  std::set<std::string_view> names;
  for (const CapError e : kAllCapErrors) {
    EXPECT_NE(to_string(e), "?");
    names.insert(to_string(e));
  }
  EXPECT_EQ(names.size(), kCapErrorCount);
}

TEST(Operation, FromWire_EveryValue_RoundTripsAndRejectsOutOfRange) {
  for (const Operation op : kAllOperations) {
    const auto back = operation_from_wire(static_cast<std::uint8_t>(op));
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(*back, op);
    EXPECT_NE(to_string(op), "?");
  }
  EXPECT_FALSE(operation_from_wire(static_cast<std::uint8_t>(kOperationCount)).has_value());
  EXPECT_FALSE(operation_from_wire(255).has_value());
}

}  // namespace
}  // namespace rejuv::cap
