// commander: builds MissionWaypoints from the mission.* params and refuses bad ones with the param's name;
// validates uploads.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <map>
#include <string>

#include "rejuv/services/commander/commander.hpp"

namespace rejuv::services {
namespace {

using Table = std::map<std::string, graph_values::Value, std::less<>>;  // as flight_io::Params::from_table

Table square_params() {
  Table t{{"mission.count", 5}, {"mission.acceptance_radius_m", 0.07}};
  const double wps[5][3] = {{0, 0, -3}, {1, 0, -3}, {1, 1, -3}, {0, 1, -3}, {0, 0, -3}};
  for (int i = 0; i < 5; ++i) {
    const std::string p = "mission." + std::to_string(i) + ".";
    t[p + "north_m"] = wps[i][0];
    t[p + "east_m"] = wps[i][1];
    t[p + "down_m"] = wps[i][2];
  }
  t["mission.2.yaw_rad"] = 0.5;
  return t;
}

TEST(Commander, Commander_MissionParams_BuildsTheMissionMessage) {
  auto c = Commander::from_params(flight_io::Params::from_table(square_params()));
  ASSERT_TRUE(c) << c.error().to_string();
  const rejuv_msg_MissionWaypoints m = c->mission_message(std::chrono::milliseconds{1});
  EXPECT_EQ(m.timestamp_ns, 1'000'000U);
  ASSERT_EQ(m.count, 5U);
  EXPECT_EQ(m.waypoints[1].p_N_m[0], 1.0);
  EXPECT_EQ(m.waypoints[2].p_N_m[1], 1.0);
  EXPECT_EQ(m.waypoints[3].p_N_m[2], -3.0);
  EXPECT_EQ(m.waypoints[2].yaw_rad, 0.5);
  EXPECT_EQ(m.waypoints[1].yaw_rad, 0.0) << "yaw is optional, 0 by default";
  EXPECT_EQ(m.acceptance_radius_m, 0.07);
  EXPECT_FALSE(c->mission().from_defaults);
}

TEST(Commander, Commander_NoMissionParams_FliesTheSimulationsDefaultSquare) {
  auto c = Commander::from_params(flight_io::Params::from_table({}));
  ASSERT_TRUE(c);
  EXPECT_TRUE(c->mission().from_defaults);
  const rejuv_msg_MissionWaypoints m = c->mission_message(Nanos{0});
  ASSERT_EQ(m.count, 5U);
  EXPECT_EQ(m.waypoints[2].p_N_m[0], 1.0);
  EXPECT_EQ(m.waypoints[2].p_N_m[1], 1.0);
  EXPECT_EQ(m.acceptance_radius_m, 0.05);
}

TEST(Commander, Commander_MoreThan16Waypoints_RefusedNamingTheCount) {
  Table t = square_params();
  t["mission.count"] = 17;
  auto c = Commander::from_params(flight_io::Params::from_table(t));
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().kind, flight_io::InputError::OutOfRange);
  EXPECT_EQ(c.error().where, "mission.count");
  EXPECT_NE(c.error().to_string().find("[1, 16]"), std::string::npos) << c.error().to_string();
}

TEST(Commander, Commander_ZeroOrFractionalCount_Refused) {
  for (const double n : {0.0, 2.5, -1.0}) {
    Table t = square_params();
    t["mission.count"] = n;
    auto c = Commander::from_params(flight_io::Params::from_table(t));
    ASSERT_FALSE(c) << n;
    EXPECT_EQ(c.error().kind, flight_io::InputError::OutOfRange);
  }
}

TEST(Commander, Commander_MissingCoordinate_RefusedNamingIt) {
  Table t = square_params();
  t.erase("mission.3.east_m");
  auto c = Commander::from_params(flight_io::Params::from_table(t));
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().kind, flight_io::InputError::Missing);
  EXPECT_EQ(c.error().where, "mission.3.east_m");
  EXPECT_EQ(c.error().to_string(),
            "mission.3.east_m: missing: waypoint 3 of 5 needs north_m, east_m and down_m");
}

TEST(Commander, Commander_NonFiniteCoordinate_RefusedNamingIt) {
  Table t = square_params();
  t["mission.1.down_m"] = std::numeric_limits<double>::infinity();
  auto c = Commander::from_params(flight_io::Params::from_table(t));
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().kind, flight_io::InputError::NotFinite);
  EXPECT_EQ(c.error().where, "mission.1.down_m");
}

TEST(Commander, Commander_NegativeAcceptanceRadius_Refused) {
  Table t = square_params();
  t["mission.acceptance_radius_m"] = -0.1;
  auto c = Commander::from_params(flight_io::Params::from_table(t));
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().where, "mission.acceptance_radius_m");
}

TEST(Commander, Commander_ValidUploadInMc_Accepted) {
  auto c = Commander::from_params(flight_io::Params::from_table({}));
  ASSERT_TRUE(c);
  const auto upload = c->validate_upload(c->mission_message(Nanos{0}), SrMode::MC);
  ASSERT_TRUE(upload) << upload.error().to_string();
  EXPECT_EQ(upload->waypoints.size(), 5U);
}

TEST(Commander, Commander_UploadOutsideMc_Refused) {
  auto c = Commander::from_params(flight_io::Params::from_table({}));
  ASSERT_TRUE(c);
  const auto upload = c->validate_upload(c->mission_message(Nanos{0}), SrMode::SC);
  ASSERT_FALSE(upload);
  EXPECT_EQ(upload.error().kind, Commander::UploadError::OutsideMissionControl);
}

TEST(Commander, Commander_UploadWithNanWaypoint_Refused) {
  auto c = Commander::from_params(flight_io::Params::from_table({}));
  ASSERT_TRUE(c);
  rejuv_msg_MissionWaypoints m = c->mission_message(Nanos{0});
  m.waypoints[4].p_N_m[0] = std::numeric_limits<double>::quiet_NaN();
  const auto upload = c->validate_upload(m, SrMode::MC);
  ASSERT_FALSE(upload);
  EXPECT_EQ(upload.error().kind, Commander::UploadError::Invalid);
  EXPECT_NE(upload.error().message.find("mission.waypoints[4]"), std::string::npos) << upload.error().message;
}

}  // namespace
}  // namespace rejuv::services
