#include <gtest/gtest.h>

#include "rejuv/core/vocabulary.hpp"

namespace rejuv {
namespace {

TEST(Rights, Parse_ValidLetters_RoundTrips) {
  const auto r = Rights::parse("WR");
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->has(Right::Read));
  EXPECT_TRUE(r->has(Right::Write));
  EXPECT_FALSE(r->has(Right::Grant));
  EXPECT_EQ(r->to_string(), "RW-");
  EXPECT_EQ(r->letters(), "RW");
}

TEST(Rights, Parse_EmptyRepeatedOrUnknown_Refused) {
  EXPECT_FALSE(Rights::parse("").has_value());
  EXPECT_FALSE(Rights::parse("RR").has_value());
  EXPECT_FALSE(Rights::parse("RX").has_value());
  EXPECT_FALSE(Rights::parse("r").has_value());
}

TEST(Rights, Contains_SubsetOnly) {
  const Rights rw = Rights{Right::Read} | Right::Write;
  EXPECT_TRUE(rw.contains(Right::Read));
  EXPECT_FALSE(Rights{Right::Read}.contains(rw));
  EXPECT_TRUE(Rights::all().contains(rw));
  EXPECT_TRUE(rw.contains(Rights::none()));
}

TEST(ModeSet, SecureInterval_IsEveryModeButMc) {
  for (const SrMode m : kAllModes) {
    EXPECT_EQ(in_secure_interval(m), m != SrMode::MC) << to_string(m);
  }
  ModeSet s;
  s.add(SrMode::RB).add(SrMode::CP);
  EXPECT_EQ(s.to_string(), "RB,CP");
  EXPECT_TRUE(ModeSet::all().has(SrMode::Update));
}

}  // namespace
}  // namespace rejuv
