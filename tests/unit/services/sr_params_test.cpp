// flight_io additions for the SR services: the cycle params (T_MC, T_est) and the actuator_limits record.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <vector>

#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/flight_io/messages.hpp"
#include "rejuv/flight_io/params.hpp"

namespace rejuv::flight_io {
namespace {

TEST(FlightIoSrParams, SrCycleParams_NoParams_AreTheSimulations) {
  const auto c = sr_cycle_params(Params::from_table({}));
  ASSERT_TRUE(c) << c.error().to_string();
  const flight::SimConfig sim = flight::SimConfig::defaults();
  EXPECT_EQ(c->t_mc, sim.t_mc);
  EXPECT_EQ(c->t_est, sim.handler.t_est);
  const flight::HandlerTiming h = c->handler_timing();
  EXPECT_EQ(h.t_est, sim.handler.t_est);
  EXPECT_EQ(h.t_min, sim.handler.t_min);
  EXPECT_EQ(h.check_period, sim.handler.check_period);
  EXPECT_DOUBLE_EQ(h.rho_s, sim.handler.rho_s);
}

// Durations cross as whole ns (rejuv/core/graph_values.hpp).
TEST(FlightIoSrParams, SrCycleParams_LaunchValues_Used) {
  const auto c = sr_cycle_params(
      Params::from_table({{"sr.t_mc_s", std::int64_t{500'000'000}}, {"sr.t_est_s", std::int64_t{1'000'000'000}}}));
  ASSERT_TRUE(c) << c.error().to_string();
  EXPECT_EQ(c->t_mc, Seconds{0.5});
  EXPECT_EQ(c->t_est, Seconds{1.0});
}

TEST(FlightIoSrParams, SrCycleParams_ZeroTmc_Refused) {
  const auto c = sr_cycle_params(Params::from_table({{"sr.t_mc_s", std::int64_t{0}}}));
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().kind, InputError::OutOfRange);
  EXPECT_EQ(c.error().where, "sr.t_mc_s");
}

TEST(FlightIoSrParams, SrCycleParams_NegativeTest_Refused) {
  const auto c = sr_cycle_params(Params::from_table({{"sr.t_est_s", std::int64_t{-1'000'000'000}}}));
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().where, "sr.t_est_s");
}

TEST(FlightIoLimits, LimitsRecord_RoundTrip_IsExact) {
  const auto limits = actuator_limits(Params::from_table({}));
  ASSERT_TRUE(limits);
  const auto bytes = limits_bytes(limits_record(limits->restricted, flight::LimitSet::Restricted));
  const auto decoded = limits_from_bytes(bytes);
  ASSERT_TRUE(decoded) << decoded.error().to_string();
  EXPECT_EQ(decoded->set, flight::LimitSet::Restricted);
  EXPECT_EQ(decoded->box.lo, limits->restricted.lo);
  EXPECT_EQ(decoded->box.hi, limits->restricted.hi);
}

TEST(FlightIoLimits, LimitsRecord_WrongSize_Refused) {
  const auto bytes = limits_bytes(limits_record(flight::InputBox{}, flight::LimitSet::Full));
  const auto decoded = limits_from_bytes(std::span<const std::byte>(bytes).first(bytes.size() - 1));
  ASSERT_FALSE(decoded);
  EXPECT_EQ(decoded.error().kind, InputError::OutOfRange);
}

TEST(FlightIoLimits, LimitsRecord_LoAboveHi_Refused) {
  LimitsRecord r{};
  r.lo[2] = 1.0;
  r.hi[2] = 0.5;
  const auto decoded = limits_from_bytes(limits_bytes(r));
  ASSERT_FALSE(decoded);
  EXPECT_EQ(decoded.error().kind, InputError::OutOfRange);
}

TEST(FlightIoLimits, LimitsRecord_NonFinite_Refused) {
  LimitsRecord r{};
  r.hi[0] = std::numeric_limits<double>::quiet_NaN();
  const auto decoded = limits_from_bytes(limits_bytes(r));
  ASSERT_FALSE(decoded);
  EXPECT_EQ(decoded.error().kind, InputError::NotFinite);
}

TEST(FlightIoLimits, LimitsRecord_UnknownVersion_Refused) {
  LimitsRecord r{};
  r.version = kLimitsRecordVersion + 1;
  EXPECT_FALSE(limits_from_bytes(limits_bytes(r)));
}

}  // namespace
}  // namespace rejuv::flight_io
