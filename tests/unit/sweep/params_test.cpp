// The swept parameters of `rejuv sweep`: ranges and lists, and launch fields set by path through reflection,
// with one test per error.
#include <gtest/gtest.h>

#include "launch.pb.h"
#include "sweep/params.hpp"

namespace rejuv::cli::sweep {
namespace {

proto::Launch base() {
  proto::Launch l;
  l.mutable_sr()->set_t_mc_s(0.3);
  l.mutable_sr()->set_t_est_s(3.0);
  proto::Attack* a = l.mutable_attack()->add_attacks();
  a->set_kind(proto::WORST_CASE_CONTROL);
  a->set_service("lqr_control");
  return l;
}

TEST(ParseNumbers, Range_InclusiveOfItsEnd) {
  const auto v = parse_numbers("0.2:0.3:0.025");
  ASSERT_TRUE(v) << v.error();
  ASSERT_EQ(v->size(), 5U);
  EXPECT_DOUBLE_EQ(v->front(), 0.2);
  EXPECT_DOUBLE_EQ((*v)[4], 0.3);  // rounded: not 0.30000000000000004
}

TEST(ParseNumbers, RangeNotOnTheGrid_StopsBelowItsEnd) {
  const auto v = parse_numbers("1:3:0.75");
  ASSERT_TRUE(v) << v.error();
  EXPECT_EQ(*v, (std::vector<double>{1, 1.75, 2.5}));
}

TEST(ParseNumbers, ListAndSingle_TakenAsWritten) {
  EXPECT_EQ(*parse_numbers("1,2.5,4"), (std::vector<double>{1, 2.5, 4}));
  EXPECT_EQ(*parse_numbers("7"), (std::vector<double>{7}));
  EXPECT_EQ(*parse_numbers("2:2:1"), (std::vector<double>{2}));
}

TEST(ParseNumbers, Empty_Refused) { EXPECT_FALSE(parse_numbers("")); }

TEST(ParseNumbers, Inverted_RefusedAsInverted) {
  const auto v = parse_numbers("3:1:0.5");
  ASSERT_FALSE(v);
  EXPECT_NE(v.error().find("inverted"), std::string::npos) << v.error();
}

TEST(ParseNumbers, StepNotPositive_Refused) {
  EXPECT_FALSE(parse_numbers("1:3:0"));
  EXPECT_FALSE(parse_numbers("1:3:-1"));
}

TEST(ParseNumbers, NotANumber_Refused) {
  EXPECT_FALSE(parse_numbers("1:x:1"));
  EXPECT_FALSE(parse_numbers("1,,2"));
  EXPECT_FALSE(parse_numbers("nan"));
  EXPECT_FALSE(parse_numbers("1:2"));
  EXPECT_FALSE(parse_numbers("1:2:3:4"));
}

TEST(ParseNumbers, TooManyValues_Refused) { EXPECT_FALSE(parse_numbers("0:1:0.00001")); }

TEST(SetField, Double_Set) {
  proto::Launch l = base();
  ASSERT_TRUE(set_field(l, "sr.t_mc_s", "0.25"));
  EXPECT_DOUBLE_EQ(l.sr().t_mc_s(), 0.25);
}

TEST(SetField, EnumOfRepeatedElement_SetByName) {
  proto::Launch l = base();
  const auto r = set_field(l, "attack.attacks[0].kind", "ARM_TIMER");
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(l.attack().attacks(0).kind(), proto::ARM_TIMER);
}

TEST(SetField, UnsetMessageOnTheWay_Created) {
  proto::Launch l = base();
  ASSERT_TRUE(set_field(l, "sr.box.position_m", "0.5"));
  EXPECT_DOUBLE_EQ(l.sr().box().position_m(), 0.5);
  ASSERT_TRUE(set_field(l, "sr.keep_generations", "3"));
  EXPECT_TRUE(l.sr().has_keep_generations());
}

TEST(SetField, BoolAndString_Set) {
  proto::Launch l = base();
  ASSERT_TRUE(set_field(l, "sr.enabled", "true"));
  EXPECT_TRUE(l.sr().enabled());
  ASSERT_TRUE(set_field(l, "name", "cell"));
  EXPECT_EQ(l.name(), "cell");
}

TEST(SetField, UnknownField_NamesTheFieldsThereAre) {
  proto::Launch l = base();
  const auto r = set_field(l, "sr.t_mcs", "1");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("has no field 't_mcs'"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("t_mc_s"), std::string::npos) << r.error();
}

TEST(SetField, UnknownTopLevelField_Refused) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "nope", "1"));
  EXPECT_FALSE(set_field(l, "", "1"));
}

TEST(SetField, MessageAsLeaf_Refused) {
  proto::Launch l = base();
  const auto r = set_field(l, "sr", "1");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("is a message"), std::string::npos) << r.error();
}

TEST(SetField, RepeatedWithoutIndex_Refused) {
  proto::Launch l = base();
  const auto r = set_field(l, "attack.attacks.kind", "ARM_TIMER");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("is repeated"), std::string::npos) << r.error();
}

TEST(SetField, IndexPastTheEnd_Refused) {
  proto::Launch l = base();
  const auto r = set_field(l, "attack.attacks[1].kind", "ARM_TIMER");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("the launch has 1 element"), std::string::npos) << r.error();
}

TEST(SetField, IndexOnSingularOrMalformed_Refused) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "sr[0].t_mc_s", "1"));
  EXPECT_FALSE(set_field(l, "attack.attacks[x].kind", "ARM_TIMER"));
  EXPECT_FALSE(set_field(l, "attack.attacks[0.kind", "ARM_TIMER"));
}

TEST(SetField, FieldOfAValue_Refused) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "sr.t_mc_s.x", "1"));
}

TEST(SetField, BadNumber_RefusedAndNothingChanged) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "sr.t_mc_s", "fast"));
  EXPECT_FALSE(set_field(l, "sr.t_mc_s", "inf"));
  EXPECT_DOUBLE_EQ(l.sr().t_mc_s(), 0.3);
}

TEST(SetField, IntegerOutOfRangeOrFractional_Refused) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "sr.keep_generations", "-1"));
  EXPECT_FALSE(set_field(l, "sr.keep_generations", "2.5"));
  EXPECT_FALSE(set_field(l, "sr.keep_generations", "5000000000"));
  EXPECT_FALSE(l.sr().has_keep_generations());
}

TEST(SetField, BadBoolOrEnumName_Refused) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "sr.enabled", "yes"));
  const auto r = set_field(l, "attack.attacks[0].kind", "SMASH");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("WORST_CASE_CONTROL"), std::string::npos) << r.error();
}

TEST(SetField, ElementOfAnEmptyList_Refused) {
  proto::Launch l = base();
  EXPECT_FALSE(set_field(l, "services[0].name", "x"));  // no services in this launch
}

TEST(MakeAxis, NumericRange_ValuesAndUnit) {
  const auto a = make_axis(base(), "sr.t_est_s=1:3:1");
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->path(), "sr.t_est_s");
  EXPECT_EQ(a->unit(), "s");
  ASSERT_EQ(a->values_size(), 3);
  EXPECT_EQ(a->values(2), "3");
}

TEST(MakeAxis, EnumList_ValuesByName) {
  const auto a = make_axis(base(), "attack.attacks[0].kind=WORST_CASE_CONTROL,ARM_TIMER");
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->values_size(), 2);
  EXPECT_EQ(a->unit(), "");
}

TEST(MakeAxis, RangeOnNonNumericField_Refused) {
  const auto a = make_axis(base(), "attack.attacks[0].kind=1:3:1");
  ASSERT_FALSE(a);
  EXPECT_NE(a.error().find("needs a numeric field"), std::string::npos) << a.error();
}

TEST(MakeAxis, NoEqualsOrNoValues_Refused) {
  EXPECT_FALSE(make_axis(base(), "sr.t_mc_s"));
  EXPECT_FALSE(make_axis(base(), "=1"));
  EXPECT_FALSE(make_axis(base(), "sr.t_mc_s="));
}

TEST(MakeAxis, BadValueInList_Refused) {
  EXPECT_FALSE(make_axis(base(), "attack.attacks[0].kind=WORST_CASE_CONTROL,NOPE"));
  EXPECT_FALSE(make_axis(base(), "sr.keep_generations=1:3:0.5"));
}

TEST(AxisLabel, SrParameters_ByThePapersNames) {
  EXPECT_EQ(axis_label("sr.t_mc_s", "s"), "T_MC [s] (sr.t_mc_s)");
  EXPECT_EQ(axis_label("sr.t_est_s", "s"), "T_est [s] (sr.t_est_s)");
  EXPECT_EQ(axis_label("sr.rho_m", ""), "ρ_M (sr.rho_m)");
  EXPECT_EQ(axis_label("plant.wind_gust_m_s", "m/s"), "plant.wind_gust_m_s [m/s]");
}

TEST(UnitOf, Suffixes_Units) {
  EXPECT_EQ(unit_of("sr.t_mc_s"), "s");
  EXPECT_EQ(unit_of("plant.wind_mean_m_s"), "m/s");
  EXPECT_EQ(unit_of("sr.rho_m"), "");  // ρ_M, ρ_s: names, not units
  EXPECT_EQ(unit_of("sr.restricted_limit_fraction"), "");
}

}  // namespace
}  // namespace rejuv::cli::sweep
