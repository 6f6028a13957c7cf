// ext_link's logic on MAVLink 2 (services/ext_link, docs/mavlink.md): the mission upload protocol as the
// vehicle's end runs it (requests, acks and error codes, a partial mission never published), malformed
// frames refused with their reason and no effect, telemetry and STATUSTEXT. The codec itself is tested in
// tests/unit/mavlink.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <string>
#include <numbers>
#include <string_view>
#include <vector>

#include "rejuv/flight_io/params.hpp"
#include "rejuv/mavlink/mission.hpp"
#include "rejuv/services/ext_link/ext_link.hpp"

namespace rejuv {
namespace {

namespace mav = rejuv::mavlink;
using Bytes = std::vector<std::byte>;
using services::ExtLink;

std::vector<mav::LocalWaypoint> square() {
  return {{.north_m = 0, .east_m = 0, .down_m = -3, .yaw_rad = 0},
          {.north_m = 2, .east_m = 0, .down_m = -3, .yaw_rad = 0.5},
          {.north_m = 2, .east_m = 2, .down_m = -3, .yaw_rad = 1.0},
          {.north_m = 0, .east_m = 2, .down_m = -3, .yaw_rad = -1.0}};
}

// Home at 3 m over the origin, the default bounds (10 m geofence, 1 m altitude floor): square() passes.
// The launch mission: home alone, acceptance radius 0.05 m.
ExtLink guarded_link() {
  const flight::PathWaypoint home{.p_N_m = Eigen::Vector3d(0, 0, -3), .yaw_rad = 0};
  return ExtLink({.home = home, .bounds = {}},
                 flight_io::MissionSpec{.waypoints = {home}, .acceptance_radius_m = 0.05, .from_defaults = false});
}
constexpr mav::GeoHome kHome = mav::kPx4SitlHome;

template <class M>
std::vector<M> all_of(const std::vector<mav::Message>& messages) {
  std::vector<M> out;
  for (const mav::Message& m : messages) {
    if (const auto* x = std::get_if<M>(&m)) out.push_back(*x);
  }
  return out;
}

std::uint8_t g_seq = 0;
Bytes bytes_of(const mav::Message& m) {
  const mav::Frame f = mav::encode(m, mav::Envelope{.seq = g_seq++, .sysid = 255, .compid = 190});
  return Bytes(f.view().begin(), f.view().end());
}

// Runs a whole upload of `waypoints` through `link` with the ground side's state machine; returns the
// vehicle's final ack and, when it forwarded one, the mission to publish.
struct UploadRun {
  std::optional<ExtLink::Forward> forward;
  std::optional<mav::MissionResult> result;
  std::vector<mav::Message> replies;  // everything the vehicle answered
};
UploadRun upload(ExtLink& link, const std::vector<mav::LocalWaypoint>& waypoints, double radius = 0.1) {
  UploadRun run;
  mav::MissionUploader ground(waypoints, radius);
  std::optional<mav::Message> next = ground.start();
  for (int guard = 0; next && guard < 100; ++guard) {
    auto in = link.on_datagram(bytes_of(*next), std::chrono::seconds{3});
    EXPECT_TRUE(in.has_value());
    if (!in) break;
    next.reset();
    std::vector<mav::Message> replies = in->replies;
    if (in->forward) {
      run.forward = in->forward;
      replies.push_back(link.forwarded(*in->forward));
    }
    for (const mav::Message& m : replies) {
      run.replies.push_back(m);
      if (const auto* a = std::get_if<mav::MissionAck>(&m)) run.result = static_cast<mav::MissionResult>(a->type);
      if (auto r = ground.on_message(m)) next = r;
    }
  }
  return run;
}

TEST(ExtLink, Upload_RequestsEachItemThenForwardsAndAccepts) {
  ExtLink link = guarded_link();
  const UploadRun run = upload(link, square());
  ASSERT_TRUE(run.forward.has_value());
  EXPECT_EQ(run.result, mav::MissionResult::Accepted);
  const rejuv_msg_MissionWaypoints& m = run.forward->upload;
  EXPECT_EQ(m.count, 4U);
  EXPECT_EQ(m.timestamp_ns, 3'000'000'000U);
  EXPECT_NEAR(m.acceptance_radius_m, 0.1, 1e-6);
  EXPECT_NEAR(m.waypoints[2].p_N_m[1], 2.0, 1e-4);
  EXPECT_NEAR(m.waypoints[3].yaw_rad, -1.0, 1e-6);
  std::size_t requests = 0;
  for (const mav::Message& r : run.replies) requests += std::holds_alternative<mav::MissionRequestInt>(r) ? 1U : 0U;
  EXPECT_EQ(requests, 4U);
  EXPECT_EQ(link.uploads_forwarded(), 1U);
}

TEST(ExtLink, PartialUpload_NeverForwarded) {
  ExtLink link = guarded_link();
  auto count = link.on_datagram(bytes_of(mav::MissionCount{.count = 3, .target_system = 1, .target_component = 1,
                                                           .mission_type = 0, .opaque_id = 0}),
                                Nanos{0});
  ASSERT_TRUE(count.has_value());
  auto item = link.on_datagram(bytes_of(mav::local_item(square()[0], 0, 0.1, 1, 1)), Nanos{0});
  ASSERT_TRUE(item.has_value());
  EXPECT_FALSE(item->forward.has_value());
  ASSERT_EQ(item->replies.size(), 1U);
  EXPECT_EQ(std::get<mav::MissionRequestInt>(item->replies[0]).seq, 1);
  EXPECT_TRUE(link.upload_in_progress());
  EXPECT_EQ(link.uploads_forwarded(), 0U);
}

TEST(ExtLink, ItemWithoutTransaction_InvalidSequenceAndGroundRestarts) {
  // A rollback wiped the transaction: the ground side is told, starts again and the mission is forwarded.
  ExtLink link = guarded_link();
  auto item = link.on_datagram(bytes_of(mav::local_item(square()[1], 1, 0.1, 1, 1)), Nanos{0});
  ASSERT_TRUE(item.has_value());
  ASSERT_EQ(item->replies.size(), 1U);
  EXPECT_EQ(std::get<mav::MissionAck>(item->replies[0]).type, static_cast<std::uint8_t>(mav::MissionResult::InvalidSequence));
  mav::MissionUploader ground(square(), 0.1);
  (void)ground.start();
  EXPECT_TRUE(std::holds_alternative<mav::MissionCount>(*ground.on_message(item->replies[0])));
  EXPECT_EQ(ground.restarts(), 1U);
}

TEST(ExtLink, OutOfOrderItem_ReRequestsTheExpectedOne) {
  ExtLink link = guarded_link();
  (void)link.on_datagram(bytes_of(mav::MissionCount{.count = 2, .target_system = 1, .target_component = 1,
                                                    .mission_type = 0, .opaque_id = 0}),
                         Nanos{0});
  auto item = link.on_datagram(bytes_of(mav::local_item(square()[1], 1, 0.1, 1, 1)), Nanos{0});
  ASSERT_TRUE(item.has_value());
  ASSERT_EQ(item->replies.size(), 1U);
  EXPECT_EQ(std::get<mav::MissionRequestInt>(item->replies[0]).seq, 0);
}

TEST(ExtLink, RepeatedUpload_AcceptedNotRepublished) {
  ExtLink link = guarded_link();
  EXPECT_TRUE(upload(link, square()).forward.has_value());
  const UploadRun again = upload(link, square());
  EXPECT_FALSE(again.forward.has_value());
  EXPECT_EQ(again.result, mav::MissionResult::Accepted);
  EXPECT_EQ(link.uploads_forwarded(), 1U);
}

TEST(ExtLink, UploadOutsideTheBounds_RefusedWithTheProtocolsErrorCode) {
  struct Case {
    std::vector<mav::LocalWaypoint> waypoints;
    mav::MissionResult result;
  };
  std::vector<Case> cases;
  auto far = square();
  far[2].east_m = 12;  // 12 m east of home: outside the 10 m geofence
  cases.push_back({far, mav::MissionResult::InvalidParam5X});
  auto low = square();
  low[1].down_m = -0.5;  // 0.5 m up: below the 1 m floor
  cases.push_back({low, mav::MissionResult::InvalidParam7});
  cases.push_back({std::vector<mav::LocalWaypoint>(17, {.north_m = 1, .east_m = 1, .down_m = -3, .yaw_rad = 0}),
                   mav::MissionResult::NoSpace});
  cases.push_back({std::vector<mav::LocalWaypoint>(16, {.north_m = 1, .east_m = 1, .down_m = -3, .yaw_rad = 0}),
                   mav::MissionResult::NoSpace});  // the path flown starts at x_sp: at most 15 uploaded
  for (const Case& c : cases) {
    ExtLink link = guarded_link();
    const UploadRun run = upload(link, c.waypoints);
    EXPECT_FALSE(run.forward.has_value());
    EXPECT_EQ(run.result, c.result) << mav::to_string(c.result);
    EXPECT_EQ(link.uploads_forwarded(), 0U);
    EXPECT_EQ(link.refused(), 0U);  // the frames were valid
  }
}

TEST(ExtLink, GlobalFrameItemWithoutHome_UnsupportedFrame) {
  ExtLink link = guarded_link();
  (void)link.on_datagram(bytes_of(mav::MissionCount{.count = 1, .target_system = 1, .target_component = 1,
                                                    .mission_type = 0, .opaque_id = 0}),
                         Nanos{0});
  mav::MissionItemInt item = mav::local_item(square()[0], 0, 0.1, 1, 1);
  item.frame = 6;  // MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
  auto r = link.on_datagram(bytes_of(item), Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(std::get<mav::MissionAck>(r->replies.at(0)).type, static_cast<std::uint8_t>(mav::MissionResult::UnsupportedFrame));
  EXPECT_FALSE(r->forward.has_value());
}

TEST(ExtLink, GlobalRelativeAltUpload_ConvertedOnceAgainstHome) {
  ExtLink link = guarded_link();
  link.set_home(kHome);
  mav::MissionUploader ground(square(), 0.1);
  ground.plan_in_global(kHome);
  // Through the same run as a local upload (upload() drives `ground`'s twin): here by hand, item by item.
  std::optional<mav::Message> next = ground.start();
  std::optional<ExtLink::Forward> forward;
  for (int guard = 0; next && guard < 20; ++guard) {
    if (const auto* item = std::get_if<mav::MissionItemInt>(&*next)) {
      EXPECT_EQ(item->frame, mav::kMavFrameGlobalRelativeAltInt);
    }
    auto in = link.on_datagram(bytes_of(*next), Nanos{0});
    ASSERT_TRUE(in.has_value());
    next.reset();
    std::vector<mav::Message> replies = in->replies;
    if (in->forward) {
      forward = in->forward;
      replies.push_back(link.forwarded(*in->forward));
    }
    for (const mav::Message& m : replies) {
      if (auto r = ground.on_message(m)) next = r;
    }
  }
  ASSERT_TRUE(forward.has_value());
  EXPECT_EQ(ground.status(), mav::MissionUploader::Status::Accepted);
  ASSERT_EQ(forward->upload.count, 4U);
  for (std::size_t i = 0; i < 4; ++i) {
    // 10⁻⁷ degree of latitude is 1.1 cm.
    EXPECT_NEAR(forward->upload.waypoints[i].p_N_m[0], square()[i].north_m, 0.02) << i;
    EXPECT_NEAR(forward->upload.waypoints[i].p_N_m[1], square()[i].east_m, 0.02) << i;
    EXPECT_NEAR(forward->upload.waypoints[i].p_N_m[2], -3.0, 1e-4) << i;
  }
}

TEST(ExtLink, GlobalAmslItem_AltitudeAboveHomeFromAmsl) {
  ExtLink link = guarded_link();
  link.set_home(kHome);
  (void)link.on_datagram(bytes_of(mav::MissionCount{.count = 1, .target_system = 1, .target_component = 1,
                                                    .mission_type = 0, .opaque_id = 0}),
                         Nanos{0});
  mav::MissionItemInt item = mav::global_item(kHome, {.north_m = 1, .east_m = 0, .down_m = -3, .yaw_rad = 0}, 0, 0.1, 1, 1);
  item.frame = mav::kMavFrameGlobalInt;
  item.z = 488.0F + 4.0F;  // AMSL: 4 m above home
  auto r = link.on_datagram(bytes_of(item), Nanos{0});
  ASSERT_TRUE(r.has_value());
  ASSERT_TRUE(r->forward.has_value());
  EXPECT_NEAR(r->forward->upload.waypoints[0].p_N_m[2], -4.0, 1e-4);
  EXPECT_NEAR(r->forward->upload.waypoints[0].p_N_m[0], 1.0, 0.02);
}

TEST(ExtLink, Download_AfterUpload_TheUploadInGlobalFrame) {
  ExtLink link = guarded_link();
  link.set_home(kHome);
  ASSERT_TRUE(upload(link, square()).forward.has_value());
  auto count = link.on_datagram(bytes_of(mav::MissionRequestList{.target_system = 1, .target_component = 1, .mission_type = 0}),
                                Nanos{0});
  ASSERT_TRUE(count.has_value());
  EXPECT_EQ(std::get<mav::MissionCount>(count->replies.at(0)).count, 4U);
  auto item = link.on_datagram(bytes_of(mav::MissionRequestInt{.seq = 2, .target_system = 1, .target_component = 1,
                                                                 .mission_type = 0}),
                               Nanos{0});
  ASSERT_TRUE(item.has_value());
  const auto& i = std::get<mav::MissionItemInt>(item->replies.at(0));
  EXPECT_EQ(i.seq, 2U);
  EXPECT_EQ(i.frame, mav::kMavFrameGlobalRelativeAltInt);
  const auto back = mav::waypoint_in_frame(i, kHome);
  ASSERT_TRUE(back.has_value());
  EXPECT_NEAR(back->north_m, 2.0, 0.02);
  EXPECT_NEAR(back->east_m, 2.0, 0.02);
  EXPECT_FLOAT_EQ(i.z, 3.0F);  // [m] above home
  auto beyond = link.on_datagram(bytes_of(mav::MissionRequestInt{.seq = 4, .target_system = 1, .target_component = 1,
                                                                   .mission_type = 0}),
                                 Nanos{0});
  ASSERT_TRUE(beyond.has_value());
  EXPECT_EQ(std::get<mav::MissionAck>(beyond->replies.at(0)).type, static_cast<std::uint8_t>(mav::MissionResult::InvalidSequence));
}

TEST(ExtLink, Download_WithoutUpload_KeptUploadElseLaunchMission) {
  ExtLink link = guarded_link();
  const auto count = [&] {
    auto r = link.on_datagram(bytes_of(mav::MissionRequestList{.target_system = 1, .target_component = 1, .mission_type = 0}),
                              Nanos{0});
    return r ? std::get<mav::MissionCount>(r->replies.at(0)).count : 999;
  };
  EXPECT_EQ(count(), 1U) << "the launch mission: home";
  flight_io::MissionSpec kept{.waypoints = {}, .acceptance_radius_m = 0.2, .from_defaults = false};
  kept.waypoints.push_back({.p_N_m = Eigen::Vector3d(1, 0, -3), .yaw_rad = 0});
  kept.waypoints.push_back({.p_N_m = Eigen::Vector3d(1, 1, -3), .yaw_rad = 0});
  link.set_kept_upload(kept);
  EXPECT_EQ(count(), 2U) << "the upload commander kept, after a rollback wiped ext_link's own memory";
}

TEST(ExtLink, FenceAndRally_AnsweredAsEmptyAndUnsupported) {
  ExtLink link = guarded_link();
  auto list = link.on_datagram(bytes_of(mav::MissionRequestList{.target_system = 1, .target_component = 1, .mission_type = 1}),
                               Nanos{0});
  ASSERT_TRUE(list.has_value());
  const auto& c = std::get<mav::MissionCount>(list->replies.at(0));
  EXPECT_EQ(c.count, 0U);
  EXPECT_EQ(c.mission_type, 1U);
  auto up = link.on_datagram(bytes_of(mav::MissionCount{.count = 2, .target_system = 1, .target_component = 1,
                                                        .mission_type = 2, .opaque_id = 0}),
                             Nanos{0});
  ASSERT_TRUE(up.has_value());
  const auto& a = std::get<mav::MissionAck>(up->replies.at(0));
  EXPECT_EQ(a.type, static_cast<std::uint8_t>(mav::MissionResult::Unsupported));
  EXPECT_EQ(a.mission_type, 2U);
  EXPECT_FALSE(link.upload_in_progress());
}

mav::CommandLong command(std::uint16_t id, float param1 = 0) {
  return mav::CommandLong{.param1 = param1, .param2 = 0, .param3 = 0, .param4 = 0, .param5 = 0, .param6 = 0, .param7 = 0,
                          .command = id, .target_system = 1, .target_component = 1, .confirmation = 0};
}

TEST(ExtLink, RequestMessage_AutopilotVersionWithItsCapabilities) {
  ExtLink link = guarded_link();
  auto r = link.on_datagram(bytes_of(command(512, 148)), Nanos{0});
  ASSERT_TRUE(r.has_value());
  const auto acks = all_of<mav::CommandAck>(r->replies);
  ASSERT_EQ(acks.size(), 1U);
  EXPECT_EQ(acks[0].command, 512U);
  EXPECT_EQ(acks[0].result, 0U);  // MAV_RESULT_ACCEPTED
  EXPECT_EQ(acks[0].target_system, 255U);
  const auto versions = all_of<mav::AutopilotVersion>(r->replies);
  ASSERT_EQ(versions.size(), 1U);
  EXPECT_NE(versions[0].capabilities & 4U, 0U) << "MISSION_INT";
  EXPECT_NE(versions[0].capabilities & 8U, 0U) << "COMMAND_INT";
  EXPECT_EQ(versions[0].capabilities & 1U, 0U) << "not MISSION_FLOAT: MISSION_ITEM is not accepted";
}

TEST(ExtLink, RequestHomePosition_WithHomeAcceptedWithoutFailed) {
  ExtLink link = guarded_link();
  auto none = link.on_datagram(bytes_of(command(512, 242)), Nanos{0});
  ASSERT_TRUE(none.has_value());
  EXPECT_EQ(all_of<mav::CommandAck>(none->replies).at(0).result, 4U);  // MAV_RESULT_FAILED
  link.set_home(kHome);
  auto r = link.on_datagram(bytes_of(command(512, 242)), Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(all_of<mav::CommandAck>(r->replies).at(0).result, 0U);
  const auto home = all_of<mav::HomePosition>(r->replies);
  ASSERT_EQ(home.size(), 1U);
  EXPECT_EQ(home[0].latitude, 473977420);
  EXPECT_EQ(home[0].longitude, 85455940);
  EXPECT_EQ(home[0].altitude, 488000);
}

TEST(ExtLink, UnknownCommand_Unsupported_DisarmDenied) {
  ExtLink link = guarded_link();
  auto r = link.on_datagram(bytes_of(command(176)), Nanos{0});  // MAV_CMD_DO_SET_MODE
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(all_of<mav::CommandAck>(r->replies).at(0).result, 3U);  // MAV_RESULT_UNSUPPORTED
  auto disarm = link.on_datagram(bytes_of(command(400, 0)), Nanos{0});
  ASSERT_TRUE(disarm.has_value());
  EXPECT_EQ(all_of<mav::CommandAck>(disarm->replies).at(0).result, 2U);  // MAV_RESULT_DENIED
  mav::CommandLong other = command(176);
  other.target_system = 7;
  auto ignored = link.on_datagram(bytes_of(other), Nanos{0});
  ASSERT_TRUE(ignored.has_value());
  EXPECT_TRUE(ignored->replies.empty()) << "a command for another system is not answered";
}

TEST(ExtLink, ReturnToLaunch_ForwardedAsAMissionToHomeThenAcked) {
  ExtLink link = guarded_link();
  auto r = link.on_datagram(bytes_of(command(20)), std::chrono::seconds{5});
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->replies.empty()) << "acknowledged only once published";
  ASSERT_TRUE(r->forward.has_value());
  EXPECT_EQ(r->forward->upload.count, 1U);
  EXPECT_DOUBLE_EQ(r->forward->upload.waypoints[0].p_N_m[2], -3.0);
  EXPECT_DOUBLE_EQ(r->forward->upload.waypoints[0].p_N_m[0], 0.0);
  const auto ack = std::get<mav::CommandAck>(link.forwarded(*r->forward));
  EXPECT_EQ(ack.command, 20U);
  EXPECT_EQ(ack.result, 0U);
}

rejuv_msg_Setpoint setpoint_at(double north_m, double east_m, double down_m, double yaw_rad = 0) {
  rejuv_msg_Setpoint sp{};
  sp.p_N_m[0] = north_m;
  sp.p_N_m[1] = east_m;
  sp.p_N_m[2] = down_m;
  sp.yaw_rad = yaw_rad;
  sp.waypoint_index = 2;
  return sp;
}

mav::MissionClearAll clear_all(std::uint8_t mission_type) {
  return mav::MissionClearAll{.target_system = 1, .target_component = 1, .mission_type = mission_type};
}

std::uint16_t download_count(ExtLink& link) {
  auto r = link.on_datagram(bytes_of(mav::MissionRequestList{.target_system = 1, .target_component = 1, .mission_type = 0}),
                            Nanos{0});
  return r ? std::get<mav::MissionCount>(r->replies.at(0)).count : 999;
}

TEST(ExtLink, ClearAll_HoldsAtTheSetpoint_AcceptedOncePublished) {
  ExtLink link = guarded_link();
  ASSERT_TRUE(upload(link, square()).forward.has_value());
  link.observe_setpoint(setpoint_at(1.5, 0.5, -3.2, 0.25));
  auto r = link.on_datagram(bytes_of(clear_all(0)), std::chrono::seconds{7});
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->replies.empty()) << "acknowledged only once published";
  ASSERT_TRUE(r->forward.has_value());
  EXPECT_EQ(r->forward->request, ExtLink::Request::Clear);
  const rejuv_msg_MissionWaypoints& hold = r->forward->upload;
  ASSERT_EQ(hold.count, 1U);
  EXPECT_DOUBLE_EQ(hold.waypoints[0].p_N_m[0], 1.5);
  EXPECT_DOUBLE_EQ(hold.waypoints[0].p_N_m[1], 0.5);
  EXPECT_DOUBLE_EQ(hold.waypoints[0].p_N_m[2], -3.2);
  EXPECT_DOUBLE_EQ(hold.waypoints[0].yaw_rad, 0.25);
  EXPECT_EQ(hold.timestamp_ns, 7'000'000'000U);
  const auto ack = std::get<mav::MissionAck>(link.forwarded(*r->forward));
  EXPECT_EQ(ack.type, static_cast<std::uint8_t>(mav::MissionResult::Accepted));
  EXPECT_EQ(ack.mission_type, 0U);
  EXPECT_EQ(ack.target_system, 255U);
  EXPECT_EQ(download_count(link), 1U) << "the mission flown now: hold at the setpoint";
  // The clear again (its ack lost): acknowledged, not published again.
  auto again = link.on_datagram(bytes_of(clear_all(0)), std::chrono::seconds{8});
  ASSERT_TRUE(again.has_value());
  EXPECT_FALSE(again->forward.has_value());
  EXPECT_EQ(std::get<mav::MissionAck>(again->replies.at(0)).type, static_cast<std::uint8_t>(mav::MissionResult::Accepted));
}

TEST(ExtLink, ClearAll_NoSetpointSeen_ErrorAndNothingPublished) {
  ExtLink link = guarded_link();
  auto r = link.on_datagram(bytes_of(clear_all(0)), Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->forward.has_value());
  EXPECT_EQ(std::get<mav::MissionAck>(r->replies.at(0)).type, static_cast<std::uint8_t>(mav::MissionResult::Error));
  EXPECT_TRUE(r->note.has_value());
}

TEST(ExtLink, ClearAll_HoldOutsideTheGeofence_ErrorAndNothingPublished) {
  ExtLink link = guarded_link();
  link.observe_setpoint(setpoint_at(0, 12, -3));  // 12 m east of home: outside the 10 m geofence
  auto r = link.on_datagram(bytes_of(clear_all(0)), Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->forward.has_value());
  EXPECT_EQ(std::get<mav::MissionAck>(r->replies.at(0)).type, static_cast<std::uint8_t>(mav::MissionResult::Error));
}

TEST(ExtLink, ClearAll_ByMissionType_FenceRallyAcceptedAllHoldsOtherUnsupported) {
  ExtLink link = guarded_link();
  link.observe_setpoint(setpoint_at(1, 0, -3));
  for (const std::uint8_t type : {std::uint8_t{1}, std::uint8_t{2}}) {
    auto r = link.on_datagram(bytes_of(clear_all(type)), Nanos{0});
    ASSERT_TRUE(r.has_value());
    EXPECT_FALSE(r->forward.has_value()) << "fence and rally: there are none";
    const auto& a = std::get<mav::MissionAck>(r->replies.at(0));
    EXPECT_EQ(a.type, static_cast<std::uint8_t>(mav::MissionResult::Accepted));
    EXPECT_EQ(a.mission_type, type);
  }
  auto other = link.on_datagram(bytes_of(clear_all(7)), Nanos{0});
  ASSERT_TRUE(other.has_value());
  EXPECT_FALSE(other->forward.has_value());
  EXPECT_EQ(std::get<mav::MissionAck>(other->replies.at(0)).type, static_cast<std::uint8_t>(mav::MissionResult::Unsupported));
  auto all = link.on_datagram(bytes_of(clear_all(255)), Nanos{0});  // MAV_MISSION_TYPE_ALL: the mission too
  ASSERT_TRUE(all.has_value());
  ASSERT_TRUE(all->forward.has_value());
  const auto ack = std::get<mav::MissionAck>(link.forwarded(*all->forward));
  EXPECT_EQ(ack.type, static_cast<std::uint8_t>(mav::MissionResult::Accepted));
  EXPECT_EQ(ack.mission_type, 255U);
}

TEST(ExtLink, EmptyUpload_ClearsAsMissionClearAll_EndingAnUploadInProgress) {
  ExtLink link = guarded_link();
  link.observe_setpoint(setpoint_at(1, 1, -3));
  auto started = link.on_datagram(bytes_of(mav::MissionCount{.count = 3, .target_system = 1, .target_component = 1,
                                                             .mission_type = 0, .opaque_id = 0}),
                                  Nanos{0});
  ASSERT_TRUE(started.has_value());
  ASSERT_TRUE(link.upload_in_progress());
  auto r = link.on_datagram(bytes_of(mav::MissionCount{.count = 0, .target_system = 1, .target_component = 1,
                                                       .mission_type = 0, .opaque_id = 0}),
                            Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(link.upload_in_progress());
  ASSERT_TRUE(r->forward.has_value());
  EXPECT_EQ(r->forward->request, ExtLink::Request::Clear);
  EXPECT_EQ(r->forward->upload.count, 1U);
}

TEST(ExtLink, Params_ListedAndNotSettable) {
  ExtLink link = guarded_link();
  link.set_home(kHome);
  auto list = link.on_datagram(bytes_of(mav::ParamRequestList{.target_system = 1, .target_component = 1}), Nanos{0});
  ASSERT_TRUE(list.has_value());
  const auto values = all_of<mav::ParamValue>(list->replies);
  ASSERT_EQ(values.size(), link.params().size());
  ASSERT_GE(values.size(), 7U);
  for (std::size_t i = 0; i < values.size(); ++i) {
    EXPECT_EQ(values[i].param_index, i);
    EXPECT_EQ(values[i].param_count, values.size());
  }
  mav::ParamSet set{.param_value = 5, .target_system = 1, .target_component = 1, .param_id = {}, .param_type = 9};
  const std::string_view name = "NAV_ACC_RAD";
  std::copy(name.begin(), name.end(), set.param_id.begin());
  auto r = link.on_datagram(bytes_of(set), Nanos{0});
  ASSERT_TRUE(r.has_value());
  const auto answered = all_of<mav::ParamValue>(r->replies);
  ASSERT_EQ(answered.size(), 1U);
  EXPECT_FLOAT_EQ(answered[0].param_value, 0.05F) << "the unchanged value";
  mav::ParamRequestRead read{.param_index = -1, .target_system = 1, .target_component = 1, .param_id = set.param_id};
  auto again = link.on_datagram(bytes_of(read), Nanos{0});
  ASSERT_TRUE(again.has_value());
  EXPECT_FLOAT_EQ(all_of<mav::ParamValue>(again->replies).at(0).param_value, 0.05F);
}

// The whole list from the params the kernel passes: the SR scheme's values (graph_values keys) as RJ_SR_*,
// switches and counts as INT32 (their bytes in param_value), durations in seconds; a key the kernel did not pass
// shows its default; a value outside its key's range refuses the service, naming the key.
TEST(ExtLink, FromParams_SrValuesListedTypedAndByteWise) {
  auto made = ExtLink::from_params(flight_io::Params::from_table({{"sr.t_mc_s", std::int64_t{250'000'000}},
                                                                  {"sr.keep_generations", std::int64_t{3}},
                                                                  {"sr.rho_m", 0.2},
                                                                  {"sr.enabled", std::int64_t{1}}}));
  ASSERT_TRUE(made.has_value()) << made.error().to_string();
  ExtLink link = std::move(*made);
  auto list = link.on_datagram(bytes_of(mav::ParamRequestList{.target_system = 1, .target_component = 1}), Nanos{0});
  ASSERT_TRUE(list.has_value());
  std::map<std::string, mav::ParamValue> by_name;
  for (const mav::ParamValue& v : all_of<mav::ParamValue>(list->replies)) {
    by_name[std::string(v.param_id.begin(), std::find(v.param_id.begin(), v.param_id.end(), '\0'))] = v;
  }
  ASSERT_EQ(by_name.size(), link.params().size()) << "every name once";
  ASSERT_EQ(by_name.count("RJ_SR_T_MC"), 1U);
  EXPECT_EQ(by_name["RJ_SR_T_MC"].param_type, 9U) << "REAL32";
  EXPECT_FLOAT_EQ(by_name["RJ_SR_T_MC"].param_value, 0.25F);
  EXPECT_FLOAT_EQ(by_name["RJ_SR_RHO_M"].param_value, 0.2F);
  EXPECT_FLOAT_EQ(by_name["RJ_SR_T_EST"].param_value, 3.0F) << "not passed: the key's default";
  EXPECT_EQ(by_name["RJ_SR_KEEP_GEN"].param_type, 6U) << "INT32";
  EXPECT_EQ(std::bit_cast<std::int32_t>(by_name["RJ_SR_KEEP_GEN"].param_value), 3);
  EXPECT_EQ(by_name["RJ_SR_ENABLED"].param_type, 6U);
  EXPECT_EQ(std::bit_cast<std::int32_t>(by_name["RJ_SR_ENABLED"].param_value), 1);
  EXPECT_FLOAT_EQ(by_name["RJ_SR_CHK_PERIOD"].param_value, 0.002F);
  EXPECT_FLOAT_EQ(by_name["NAV_ACC_RAD"].param_value, 0.05F);
  for (const auto& [name, value] : by_name) EXPECT_LE(name.size(), 16U);
  // PARAM_SET of an INT32 one: refused, answered with the unchanged value and its type.
  mav::ParamSet set{.param_value = std::bit_cast<float>(std::int32_t{5}), .target_system = 1, .target_component = 1,
                    .param_id = by_name["RJ_SR_KEEP_GEN"].param_id, .param_type = 6};
  auto r = link.on_datagram(bytes_of(set), Nanos{0});
  ASSERT_TRUE(r.has_value());
  const auto answered = all_of<mav::ParamValue>(r->replies);
  ASSERT_EQ(answered.size(), 1U);
  EXPECT_EQ(std::bit_cast<std::int32_t>(answered[0].param_value), 3);
  EXPECT_EQ(answered[0].param_type, 6U);
}

// A run without SR (a graph without an `sr` block passes sr.enabled 0 and zero durations): only RJ_SR_ENABLED.
TEST(ExtLink, FromParams_SrOff_OnlyTheSwitchListed) {
  auto made = ExtLink::from_params(flight_io::Params::from_table({{"sr.enabled", std::int64_t{0}},
                                                                  {"sr.t_mc_s", std::int64_t{0}}}));
  ASSERT_TRUE(made.has_value()) << made.error().to_string();
  std::size_t sr_params = 0;
  for (const ExtLink::Param& p : made->params()) {
    if (!p.name.starts_with("RJ_SR_")) continue;
    ++sr_params;
    EXPECT_EQ(p.name, "RJ_SR_ENABLED");
    EXPECT_EQ(std::get<std::int32_t>(p.value), 0);
  }
  EXPECT_EQ(sr_params, 1U);
}

TEST(ExtLink, FromParams_SrValueOutOfItsRange_RefusedNamingTheKey) {
  auto made = ExtLink::from_params(flight_io::Params::from_table({{"sr.keep_generations", std::int64_t{40}}}));
  ASSERT_FALSE(made.has_value());
  EXPECT_NE(made.error().to_string().find("sr.keep_generations"), std::string::npos) << made.error().to_string();
}

TEST(ExtLink, AutopilotVersion_SaysParamsAreEncodedByteWise) {
  ExtLink link = guarded_link();
  auto r = link.on_datagram(bytes_of(command(512, 148)), Nanos{0});
  ASSERT_TRUE(r.has_value());
  EXPECT_NE(all_of<mav::AutopilotVersion>(r->replies).at(0).capabilities & 16U, 0U) << "PARAM_ENCODE_BYTEWISE";
}

TEST(ExtLink, TelemetryWithHomeAndGps_HomeGpsHealthAndLandedState) {
  ExtLink link = guarded_link();
  link.set_home(kHome);
  rejuv_msg_VehicleStateEstimate x{};
  x.timestamp_ns = 1;
  x.p_N_m[2] = -3;
  x.q_NB[0] = 1;
  rejuv_msg_SensorGps gps{};
  gps.timestamp_ns = 1'000'000;
  gps.p_N_m[0] = 111.32;
  gps.p_N_m[2] = -3;
  gps.fix_type = 3;
  gps.satellites_used = 10;
  gps.eph_m = 0.5;
  const auto out = link.telemetry({.now = std::chrono::seconds{2}, .state = &x, .setpoint = nullptr, .gps = &gps,
                                   .mode = SrMode::MC, .epoch = Epoch{1}});
  const auto raw = all_of<mav::GpsRawInt>(out);
  ASSERT_EQ(raw.size(), 1U);
  EXPECT_NEAR(raw[0].lat, 473987420, 20);
  EXPECT_EQ(raw[0].alt, 491000);
  EXPECT_EQ(raw[0].fix_type, 3U);
  EXPECT_EQ(raw[0].h_acc, 500U);
  const auto sys = all_of<mav::SysStatus>(out).at(0);
  EXPECT_NE(sys.onboard_control_sensors_health & 32U, 0U) << "GPS healthy: a new sample with a 3D fix";
  EXPECT_NE(sys.onboard_control_sensors_health & 1U, 0U) << "gyro healthy: a new estimate";
  EXPECT_EQ(sys.onboard_control_sensors_health & 1024U, 0U) << "no setpoint seen: the control loops are not";
  EXPECT_EQ(all_of<mav::ExtendedSysState>(out).at(0).landed_state, 2U);  // MAV_LANDED_STATE_IN_AIR
  EXPECT_EQ(all_of<mav::HomePosition>(out).size(), 1U);
  // A second later with nothing new: no longer healthy, and the same GPS sample is not sent again.
  const auto stale = link.telemetry({.now = std::chrono::seconds{3}, .state = &x, .setpoint = nullptr, .gps = &gps,
                                     .mode = SrMode::MC, .epoch = Epoch{1}});
  EXPECT_TRUE(all_of<mav::GpsRawInt>(stale).empty());
  EXPECT_EQ(all_of<mav::SysStatus>(stale).at(0).onboard_control_sensors_health, 0U);
}

TEST(ExtLink, UploadFlown_ItemReachedCountsItemsNotPathIndices) {
  ExtLink link = guarded_link();
  ASSERT_TRUE(upload(link, square()).forward.has_value());
  rejuv_msg_Setpoint sp{};
  const auto reached_at = [&](std::uint32_t index, bool done, std::chrono::milliseconds t) {
    sp.waypoint_index = index;
    sp.mission_done = done ? 1 : 0;
    std::vector<std::uint16_t> seqs;
    for (const auto& r : all_of<mav::MissionItemReached>(
             link.telemetry({.now = t, .state = nullptr, .setpoint = &sp, .mode = SrMode::MC, .epoch = Epoch{1}}))) {
      seqs.push_back(r.seq);
    }
    return seqs;
  };
  // The path flown is [the setpoint at the update, item 0, …, item 3]: index 1 is item 0.
  EXPECT_TRUE(reached_at(1, false, std::chrono::milliseconds{0}).empty());
  EXPECT_EQ(reached_at(2, false, std::chrono::milliseconds{100}), std::vector<std::uint16_t>{0});
  EXPECT_EQ(reached_at(3, false, std::chrono::milliseconds{200}), std::vector<std::uint16_t>{1});
  EXPECT_EQ(reached_at(4, false, std::chrono::milliseconds{300}), std::vector<std::uint16_t>{2});
  EXPECT_EQ(reached_at(4, true, std::chrono::milliseconds{400}), std::vector<std::uint16_t>{3}) << "the last, when done";
  EXPECT_TRUE(reached_at(4, true, std::chrono::milliseconds{500}).empty());
}

TEST(ExtLink, MalformedFrames_CountedByReasonWithoutEffect) {
  ExtLink link = guarded_link();
  Bytes bad_start = bytes_of(mav::Heartbeat{});
  bad_start[0] = std::byte{0xFE};
  Bytes bad_crc = bytes_of(mav::local_item(square()[1], 0, 0.1, 1, 1));
  bad_crc[14] ^= std::byte{1};
  EXPECT_FALSE(link.on_datagram({}, Nanos{0}).has_value());
  EXPECT_FALSE(link.on_datagram(bad_start, Nanos{0}).has_value());
  EXPECT_FALSE(link.on_datagram(bad_crc, Nanos{0}).has_value());
  EXPECT_EQ(link.refused(), 3U);
  EXPECT_EQ(link.refused(mav::DecodeError::TooShort), 1U);
  EXPECT_EQ(link.refused(mav::DecodeError::BadStart), 1U);
  EXPECT_EQ(link.refused(mav::DecodeError::BadChecksum), 1U);
  EXPECT_FALSE(link.upload_in_progress());
  EXPECT_EQ(link.uploads_forwarded(), 0U);
}

TEST(ExtLink, Telemetry_HeartbeatOncePerSecondPositionEveryTime) {
  ExtLink link = guarded_link();
  rejuv_msg_VehicleStateEstimate x{};
  x.p_N_m[0] = 0.5;
  x.p_N_m[2] = -2.9;
  x.v_N_m_s[1] = 0.2;
  x.q_NB[0] = 1;
  rejuv_msg_Setpoint sp{};
  sp.waypoint_index = 2;
  const auto at = [&](std::chrono::milliseconds t) {
    return link.telemetry({.now = t, .state = &x, .setpoint = &sp, .mode = SrMode::MC, .epoch = Epoch{3}});
  };
  const auto first = at(std::chrono::milliseconds{1500});
  const auto* hb = std::get_if<mav::Heartbeat>(&first.at(0));
  ASSERT_NE(hb, nullptr);
  EXPECT_EQ(hb->type, mav::kMavTypeQuadrotor);
  EXPECT_EQ(hb->custom_mode, services::custom_mode_of(SrMode::MC, Epoch{3}));
  EXPECT_EQ(hb->custom_mode >> 8U, 3U);
  const auto* lp = std::get_if<mav::LocalPositionNed>(&first.at(first.size() - 3));
  ASSERT_NE(lp, nullptr);
  EXPECT_EQ(lp->time_boot_ms, 1500U);
  EXPECT_FLOAT_EQ(lp->x, 0.5F);
  EXPECT_FLOAT_EQ(lp->z, -2.9F);
  EXPECT_FLOAT_EQ(lp->vy, 0.2F);
  EXPECT_TRUE(std::holds_alternative<mav::Attitude>(first.at(first.size() - 2)));
  EXPECT_TRUE(std::holds_alternative<mav::VfrHud>(first.back()));
  const auto soon = at(std::chrono::milliseconds{1600});
  EXPECT_EQ(soon.size(), 3U) << "no HEARTBEAT within the second";
  const auto later = at(std::chrono::milliseconds{2500});
  EXPECT_TRUE(std::holds_alternative<mav::Heartbeat>(later.at(0)));
}

TEST(ExtLink, HomeOnEarth_GlobalPositionIntFromTheLocalEstimate) {
  ExtLink link = guarded_link();
  rejuv_msg_VehicleStateEstimate x{};
  x.p_N_m[0] = 111.32;  // ≈ 0.001° of latitude
  x.p_N_m[2] = -3;
  x.v_N_m_s[1] = 0.5;
  x.q_NB[0] = std::cos(std::numbers::pi / 4);  // yaw 90°: heading east
  x.q_NB[3] = std::sin(std::numbers::pi / 4);
  const auto none = link.telemetry({.now = Nanos{0}, .state = &x, .setpoint = nullptr, .mode = SrMode::MC, .epoch = Epoch{1}});
  EXPECT_TRUE(std::none_of(none.begin(), none.end(), [](const mav::Message& m) { return std::holds_alternative<mav::GlobalPositionInt>(m); }));
  link.set_home({.lat_deg = 47.397742, .lon_deg = 8.545594, .alt_m = 488});
  const auto out = link.telemetry({.now = std::chrono::milliseconds{100}, .state = &x, .setpoint = nullptr, .mode = SrMode::MC, .epoch = Epoch{1}});
  const auto it = std::find_if(out.begin(), out.end(), [](const mav::Message& m) { return std::holds_alternative<mav::GlobalPositionInt>(m); });
  ASSERT_NE(it, out.end());
  const auto& g = std::get<mav::GlobalPositionInt>(*it);
  EXPECT_NEAR(g.lat, 473987420, 20);  // 47.397742° + 0.001°
  EXPECT_EQ(g.lon, 85455940);
  EXPECT_EQ(g.alt, 491000);           // 488 m + 3 m [mm]
  EXPECT_EQ(g.relative_alt, 3000);
  EXPECT_EQ(g.vy, 50);                // [cm/s]
  EXPECT_EQ(g.hdg, 9000);             // [cdeg]
}

TEST(ExtLink, SetpointMovesOn_MissionItemReachedForThePreviousWaypoint) {
  ExtLink link = guarded_link();
  rejuv_msg_Setpoint sp{};
  sp.waypoint_index = 1;
  const auto at = [&](std::chrono::milliseconds t) {
    std::vector<std::uint16_t> reached;
    for (const mav::Message& m :
         link.telemetry({.now = t, .state = nullptr, .setpoint = &sp, .mode = SrMode::MC, .epoch = Epoch{1}})) {
      if (const auto* r = std::get_if<mav::MissionItemReached>(&m)) reached.push_back(r->seq);
    }
    return reached;
  };
  EXPECT_TRUE(at(std::chrono::milliseconds{0}).empty());
  EXPECT_TRUE(at(std::chrono::milliseconds{100}).empty());
  sp.waypoint_index = 2;
  EXPECT_EQ(at(std::chrono::milliseconds{200}), std::vector<std::uint16_t>{1});
  EXPECT_TRUE(at(std::chrono::milliseconds{300}).empty());
}

TEST(ExtLink, Rollback_QueuesOneStatusTextSentInMc) {
  ExtLink link = guarded_link();
  link.observe({.mode = SrMode::MC, .epoch = Epoch{1}});
  link.observe({.mode = SrMode::RB, .epoch = Epoch{2}});
  EXPECT_EQ(link.pending_texts(), 2U);  // the rollback and the mode
  link.observe({.mode = SrMode::MC, .epoch = Epoch{2}});
  const auto out = link.telemetry({.now = Nanos{0}, .state = nullptr, .setpoint = nullptr, .mode = SrMode::MC, .epoch = Epoch{2}});
  std::vector<std::string> texts;
  for (const mav::Message& m : out) {
    if (const auto* t = std::get_if<mav::StatusText>(&m)) texts.push_back(mav::text_of(*t));
  }
  ASSERT_EQ(texts.size(), 3U);
  EXPECT_NE(texts[0].find("rollback"), std::string::npos) << texts[0];
  EXPECT_EQ(texts[1], "SR mode RB");
  EXPECT_EQ(link.pending_texts(), 0U);
}

TEST(ExtLink, TextsOfAnOlderEpoch_DroppedAtTheNextRollback) {
  ExtLink link = guarded_link();
  link.observe({.mode = SrMode::CP, .epoch = Epoch{1}});
  link.observe({.mode = SrMode::MC, .epoch = Epoch{1}});
  EXPECT_EQ(link.pending_texts(), 1U);
  link.observe({.mode = SrMode::RB, .epoch = Epoch{2}});
  EXPECT_EQ(link.pending_texts(), 2U) << "the old epoch's text dropped; the rollback and RB queued";
}

TEST(ExtLink, SecurityEvent_StatusTextWithItsSeverity) {
  ExtLink link = guarded_link();
  link.observe({.mode = SrMode::MC, .epoch = Epoch{1}});
  rejuv_msg_SecurityEvent e{};
  e.kind = rejuv_msg_SECURITY_FORBIDDEN_CALL;
  e.service_id = 4;
  link.observe({.mode = SrMode::MC, .epoch = Epoch{1}, .security_events = 2, .latest_event = &e});
  const auto out = link.telemetry({.now = Nanos{0}, .state = nullptr, .setpoint = nullptr, .mode = SrMode::MC, .epoch = Epoch{1}});
  const auto* t = std::get_if<mav::StatusText>(&out.at(0));
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->severity, static_cast<std::uint8_t>(mav::Severity::Critical));
  EXPECT_EQ(mav::text_of(*t), "security: forbidden call, service 4, 2 new");
}

TEST(ExtLink, RefusalLog_AtMostOncePerSecondOfKernelTime) {
  ExtLink link = guarded_link();
  std::uint64_t suppressed = 99;
  EXPECT_TRUE(link.should_log_refusal(Nanos{0}, suppressed));
  EXPECT_EQ(suppressed, 0U);
  EXPECT_FALSE(link.should_log_refusal(std::chrono::milliseconds{10}, suppressed));
  EXPECT_FALSE(link.should_log_refusal(std::chrono::milliseconds{999}, suppressed));
  EXPECT_TRUE(link.should_log_refusal(std::chrono::milliseconds{1000}, suppressed));
  EXPECT_EQ(suppressed, 2U);
}

}  // namespace
}  // namespace rejuv
