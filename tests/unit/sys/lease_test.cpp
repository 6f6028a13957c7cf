// Slot leases (rejuv/sys/lease.hpp): DDS domains (the test processes, `rejuv sweep`) and service uid blocks.
#include <gtest/gtest.h>

#include <optional>

#include "rejuv/sys/lease.hpp"

namespace rejuv::sys {
namespace {

TEST(DdsDomainLease, TwoLeasesOfOneProcess_DifferentDomains) {
  auto a = lease_dds_domain(17);
  auto b = lease_dds_domain(17);
  ASSERT_TRUE(a) << a.error().to_string();
  ASSERT_TRUE(b) << b.error().to_string();
  EXPECT_NE(a->slot(), b->slot());
  EXPECT_GE(a->slot(), 1U);
  EXPECT_LE(a->slot(), kLeasedDdsDomains);
}

TEST(DdsDomainLease, Dropped_DomainFreeAgain) {
  std::optional<DdsDomainLease> a;
  {
    auto taken = lease_dds_domain(123);
    ASSERT_TRUE(taken);
    a.emplace(std::move(*taken));
  }
  const std::uint32_t held = a->slot();
  a.reset();
  // The same hint finds the same domain again, unless another process took it meanwhile (then a later one).
  auto again = lease_dds_domain(held - 1);
  ASSERT_TRUE(again);
  if (again->slot() != held) GTEST_SKIP() << "domain " << held << " taken by another process meanwhile";
  EXPECT_EQ(again->slot(), held);
}

TEST(UidBlockLease, TwoKernelsOfOneMachine_DisjointUids) {
  auto a = lease_uid_block(5);
  auto b = lease_uid_block(5);
  ASSERT_TRUE(a) << a.error().to_string();
  ASSERT_TRUE(b) << b.error().to_string();
  EXPECT_NE(a->slot(), b->slot());
  EXPECT_LT(a->slot(), kUidBlocks);
  // The blocks' uid ranges do not overlap (that none reaches nobody is a static_assert of lease.hpp).
  const std::uint32_t last = kUidsPerBlock - 1;
  EXPECT_TRUE(service_uid(*a, last) < service_uid(*b, 0) || service_uid(*b, last) < service_uid(*a, 0));
}

}  // namespace
}  // namespace rejuv::sys
