// DDS domain leases (rejuv/sys/dds_domain.hpp): shared by the test processes and `rejuv sweep`.
#include <gtest/gtest.h>

#include <optional>

#include "rejuv/sys/dds_domain.hpp"

namespace rejuv::sys {
namespace {

TEST(DdsDomainLease, TwoLeasesOfOneProcess_DifferentDomains) {
  auto a = lease_dds_domain(17);
  auto b = lease_dds_domain(17);
  ASSERT_TRUE(a) << a.error().to_string();
  ASSERT_TRUE(b) << b.error().to_string();
  EXPECT_NE(a->domain(), b->domain());
  EXPECT_GE(a->domain(), 1U);
  EXPECT_LE(a->domain(), kLeasedDdsDomains);
}

TEST(DdsDomainLease, Dropped_DomainFreeAgain) {
  std::optional<DdsDomainLease> a;
  {
    auto taken = lease_dds_domain(123);
    ASSERT_TRUE(taken);
    a.emplace(std::move(*taken));
  }
  const std::uint32_t held = a->domain();
  a.reset();
  // The same hint finds the same domain again, unless another process took it meanwhile (then a later one).
  auto again = lease_dds_domain(held - 1);
  ASSERT_TRUE(again);
  if (again->domain() != held) GTEST_SKIP() << "domain " << held << " taken by another process meanwhile";
  EXPECT_EQ(again->domain(), held);
}

}  // namespace
}  // namespace rejuv::sys
