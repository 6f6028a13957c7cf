// gen_set_point: the simulation's setpoint generator on messages — it advances along the square by the
// no-SR tracking rule or on update requests (SR), and sets mission_done at the end.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <vector>

#include "default_design_fixture.hpp"
#include "rejuv/services/gen_set_point/setpoint_node.hpp"

namespace rejuv::services {
namespace {

using std::chrono::milliseconds;

rejuv_msg_VehicleStateEstimate estimate_at(const flight::StateVec& x, Nanos t) {
  rejuv_msg_VehicleStateEstimate m{};
  m.timestamp_ns = flight_io::stamp(t);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(x[flight::idx::kYaw], Eigen::Vector3d::UnitZ()));
  for (int i = 0; i < 3; ++i) m.p_N_m[i] = x[flight::idx::kPos + i];
  m.q_NB[0] = q.w();
  m.q_NB[1] = q.x();
  m.q_NB[2] = q.y();
  m.q_NB[3] = q.z();
  return m;
}

rejuv_msg_SetpointUpdateRequest request_at(Nanos t, double rho_m = 0.0) {
  rejuv_msg_SetpointUpdateRequest m{};
  m.timestamp_ns = flight_io::stamp(t);
  m.rho_m = rho_m;
  return m;
}

class SetpointNodeTest : public testing::DefaultDesignTest {
 protected:
  void SetUp() override {
    ASSERT_TRUE(design_.has_value());
    auto m = flight_io::mission_params(flight_io::Params::from_table({}));
    ASSERT_TRUE(m);
    square_ = flight_io::mission_message(*m, Nanos{0});
  }

  SetpointNode make(flight::SrSwitch sr) {
    auto t = flight_io::tracking_params(flight_io::Params::from_table({}));
    EXPECT_TRUE(t);
    t->sr = sr;
    return SetpointNode(design_->ellipsoid, *t);
  }

  rejuv_msg_MissionWaypoints square_{};
};

TEST_F(SetpointNodeTest, SetpointNode_BeforeAMission_NothingToPublish) {
  SetpointNode node = make(flight::SrSwitch::On);
  ASSERT_TRUE(node.on_state(estimate_at(flight::hover_setpoint({0, 0, -3}, 0), milliseconds{1})));
  EXPECT_EQ(node.on_update_request(request_at(milliseconds{2})), SetpointNode::RequestOutcome::Ignored);
  EXPECT_FALSE(node.take_changed().has_value());
}

TEST_F(SetpointNodeTest, SetpointNode_Mission_PublishesTheFirstWaypointOnce) {
  SetpointNode node = make(flight::SrSwitch::On);
  ASSERT_TRUE(node.on_mission(square_));
  const auto sp = node.take_changed();
  ASSERT_TRUE(sp.has_value());
  EXPECT_EQ(*flight_io::setpoint_from_message(*sp), flight::hover_setpoint({0, 0, -3}, 0));
  EXPECT_EQ(sp->waypoint_index, 1U);
  EXPECT_EQ(sp->mission_done, 0);
  EXPECT_FALSE(node.take_changed().has_value());
}

TEST_F(SetpointNodeTest, SetpointNode_WithoutSr_AdvancesAlongTheSquareAndFinishes) {
  // Given perfect tracking (x̂ = x_sp at every estimate) and no SR,
  SetpointNode node = make(flight::SrSwitch::Off);
  ASSERT_TRUE(node.on_mission(square_));
  std::vector<rejuv_msg_Setpoint> published;
  flight::StateVec x_sp = *flight_io::setpoint_from_message(*node.take_changed());
  // when estimates arrive at the IMU rate,
  for (Nanos t = milliseconds{1}; t < std::chrono::seconds{120} && !node.mission_done();
       t += milliseconds{4}) {
    ASSERT_TRUE(node.on_state(estimate_at(x_sp, t)));
    if (auto sp = node.take_changed()) {
      published.push_back(*sp);
      x_sp = *flight_io::setpoint_from_message(*sp);
    }
  }
  // then the setpoint has moved forward through every waypoint to the last one, and the mission is done.
  ASSERT_TRUE(node.mission_done());
  ASSERT_GT(published.size(), 8U);
  std::uint32_t index = 1;
  for (const rejuv_msg_Setpoint& sp : published) {
    EXPECT_GE(sp.waypoint_index, index) << "the setpoint never goes back";
    index = sp.waypoint_index;
  }
  EXPECT_EQ(published.back().waypoint_index, 4U);
  EXPECT_EQ(published.back().mission_done, 1);
  EXPECT_LT((x_sp - flight::hover_setpoint({0, 0, -3}, 0)).norm(), 1e-12)
      << "back at the start of the square";
  EXPECT_EQ(node.generator()->cursor().progress(), 4.0);
  // Every move kept x̂ (the previous setpoint) inside E(ρ_M, x_sp').
  flight::StateVec previous = flight::hover_setpoint({0, 0, -3}, 0);
  for (const rejuv_msg_Setpoint& sp : published) {
    const flight::StateVec next = *flight_io::setpoint_from_message(sp);
    EXPECT_LE(design_->ellipsoid.norm(previous, next), 0.1 + 1e-9);
    previous = next;
  }
}

TEST_F(SetpointNodeTest, SetpointNode_WithoutSr_MovesAtMostOncePerTmin) {
  SetpointNode node = make(flight::SrSwitch::Off);
  ASSERT_TRUE(node.on_mission(square_));
  flight::StateVec x_sp = *flight_io::setpoint_from_message(*node.take_changed());
  std::vector<Nanos> moves;
  for (Nanos t = milliseconds{1}; t < milliseconds{200}; t += milliseconds{4}) {
    ASSERT_TRUE(node.on_state(estimate_at(x_sp, t)));
    if (auto sp = node.take_changed()) {
      moves.push_back(flight_io::time_of(sp->timestamp_ns));
      x_sp = *flight_io::setpoint_from_message(*sp);
    }
  }
  ASSERT_GE(moves.size(), 2U);
  for (std::size_t i = 1; i < moves.size(); ++i) EXPECT_GE(moves[i] - moves[i - 1], milliseconds{20});
}

TEST_F(SetpointNodeTest, SetpointNode_WithoutSr_EstimateOutsideRhoS_Holds) {
  SetpointNode node = make(flight::SrSwitch::Off);
  ASSERT_TRUE(node.on_mission(square_));
  (void)node.take_changed();
  const flight::StateVec far = flight::hover_setpoint({0.3, -0.3, -3}, 0);  // well outside E(ρ_s)
  for (Nanos t = milliseconds{1}; t < milliseconds{100}; t += milliseconds{4}) {
    ASSERT_TRUE(node.on_state(estimate_at(far, t)));
  }
  EXPECT_FALSE(node.take_changed().has_value());
  EXPECT_EQ(node.generator()->cursor().progress(), 0.0);
}

TEST_F(SetpointNodeTest, SetpointNode_WithSr_MovesOnlyOnUpdateRequests) {
  SetpointNode node = make(flight::SrSwitch::On);
  ASSERT_TRUE(node.on_mission(square_));
  const flight::StateVec start = *flight_io::setpoint_from_message(*node.take_changed());
  for (Nanos t = milliseconds{1}; t < milliseconds{100}; t += milliseconds{4}) {
    ASSERT_TRUE(node.on_state(estimate_at(start, t)));
  }
  EXPECT_FALSE(node.take_changed().has_value()) << "with SR the estimate alone never moves x_sp";
  EXPECT_EQ(node.on_update_request(request_at(milliseconds{101})), SetpointNode::RequestOutcome::Moved);
  const auto sp = node.take_changed();
  ASSERT_TRUE(sp.has_value());
  const flight::StateVec moved = *flight_io::setpoint_from_message(*sp);
  EXPECT_GT(moved[0], 0.0) << "toward waypoint 1 (north)";
  EXPECT_NEAR(design_->ellipsoid.norm(start, moved), 0.1, 1e-6) << "as far as keeps x̂ in E(ρ_M, x_sp')";
  EXPECT_EQ(sp->timestamp_ns, 101'000'000U);
}

TEST_F(SetpointNodeTest, SetpointNode_RequestWithItsOwnRhoM_UsesIt) {
  SetpointNode node = make(flight::SrSwitch::On);
  ASSERT_TRUE(node.on_mission(square_));
  const flight::StateVec start = *flight_io::setpoint_from_message(*node.take_changed());
  ASSERT_TRUE(node.on_state(estimate_at(start, milliseconds{1})));
  ASSERT_EQ(node.on_update_request(request_at(milliseconds{2}, 0.05)), SetpointNode::RequestOutcome::Moved);
  EXPECT_NEAR(design_->ellipsoid.norm(start, node.generator()->setpoint()), 0.05, 1e-6);
}

TEST_F(SetpointNodeTest, SetpointNode_WithoutSr_UpdateRequestsIgnored) {
  SetpointNode node = make(flight::SrSwitch::Off);
  ASSERT_TRUE(node.on_mission(square_));
  (void)node.take_changed();
  const flight::StateVec far = flight::hover_setpoint({0.3, -0.3, -3}, 0);
  ASSERT_TRUE(node.on_state(estimate_at(far, milliseconds{1})));
  EXPECT_EQ(node.on_update_request(request_at(milliseconds{2})), SetpointNode::RequestOutcome::Ignored);
}

TEST_F(SetpointNodeTest, SetpointNode_SameMissionAgain_KeepsItsProgress) {
  SetpointNode node = make(flight::SrSwitch::On);
  ASSERT_TRUE(node.on_mission(square_));
  const flight::StateVec start = *flight_io::setpoint_from_message(*node.take_changed());
  ASSERT_TRUE(node.on_state(estimate_at(start, milliseconds{1})));
  ASSERT_EQ(node.on_update_request(request_at(milliseconds{2})), SetpointNode::RequestOutcome::Moved);
  (void)node.take_changed();
  const double progress = node.generator()->cursor().progress();
  ASSERT_TRUE(node.on_mission(square_));
  EXPECT_EQ(node.generator()->cursor().progress(), progress);
  EXPECT_FALSE(node.take_changed().has_value());
}

TEST_F(SetpointNodeTest, SetpointNode_LastWaypointButEstimateAway_NotDone) {
  // Given a one-waypoint mission whose setpoint has reached its (only) waypoint,
  rejuv_msg_MissionWaypoints one{};
  one.count = 1;
  one.waypoints[0].p_N_m[2] = -3;
  one.acceptance_radius_m = 0.05;
  SetpointNode node = make(flight::SrSwitch::On);
  ASSERT_TRUE(node.on_mission(one));
  (void)node.take_changed();
  ASSERT_TRUE(node.on_state(estimate_at(flight::hover_setpoint({0.1, 0, -3}, 0), milliseconds{1})));
  ASSERT_EQ(node.on_update_request(request_at(milliseconds{2})), SetpointNode::RequestOutcome::Moved);
  ASSERT_TRUE(node.generator()->finished());
  (void)node.take_changed();
  // when the estimate is 0.1 m away the mission is not done; at 0.03 m (< 0.05 m) it is.
  ASSERT_TRUE(node.on_state(estimate_at(flight::hover_setpoint({0.1, 0, -3}, 0), milliseconds{5})));
  EXPECT_FALSE(node.mission_done());
  EXPECT_FALSE(node.take_changed().has_value());
  ASSERT_TRUE(node.on_state(estimate_at(flight::hover_setpoint({0.03, 0, -3}, 0), milliseconds{9})));
  EXPECT_TRUE(node.mission_done());
  const auto sp = node.take_changed();
  ASSERT_TRUE(sp.has_value());
  EXPECT_EQ(sp->mission_done, 1);
  EXPECT_EQ(sp->timestamp_ns, 9'000'000U) << "stamped when it happened";
}

TEST_F(SetpointNodeTest, SetpointNode_MissionWithTooManyWaypoints_Refused) {
  rejuv_msg_MissionWaypoints bad = square_;
  bad.count = 17;
  SetpointNode node = make(flight::SrSwitch::On);
  const auto r = node.on_mission(bad);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, flight_io::InputError::OutOfRange);
  EXPECT_EQ(node.generator(), nullptr);
}

// Cold restart (docs/design.md §7): the record kept by one incarnation restores x_sp and the waypoint in the next,
// through the cell's bytes, and the launch mission commander publishes at boot does not send it back to 0.
TEST_F(SetpointNodeTest, SetpointNode_RestoredFromItsRecord_ContinuesWhereItWasNotAtWaypointZero) {
  SetpointNode before = make(flight::SrSwitch::On);
  ASSERT_TRUE(before.on_mission(square_));
  (void)before.take_changed();
  flight::StateVec x_hat = flight::hover_setpoint({0, 0, -3}, 0);
  for (int i = 0; i < 40; ++i) {  // perfect tracking: well into the second side
    ASSERT_TRUE(before.on_state(estimate_at(x_hat, milliseconds{10 * i + 1})));
    (void)before.on_update_request(request_at(milliseconds{10 * i + 2}));
    x_hat = before.generator()->setpoint();
  }
  ASSERT_GE(before.generator()->target_waypoint(), 2U);
  const auto record = before.record();
  ASSERT_TRUE(record.has_value());
  const flight_io::MissionRecordBytes bytes = flight_io::encode_mission_record(*record);

  SetpointNode after = make(flight::SrSwitch::On);
  auto decoded = flight_io::decode_mission_record(bytes);
  ASSERT_TRUE(decoded && decoded->has_value());
  ASSERT_TRUE(after.restore(**decoded, milliseconds{500}));
  ASSERT_TRUE(after.on_mission(square_));  // commander's boot mission: ignored
  const auto sp = after.take_changed();
  ASSERT_TRUE(sp.has_value());
  EXPECT_TRUE(flight_io::setpoint_from_message(*sp)->isApprox(before.generator()->setpoint(), 1e-12));
  EXPECT_EQ(sp->waypoint_index, before.generator()->target_waypoint());
}

TEST_F(SetpointNodeTest, MissionRecord_NeverWrittenCell_DecodesAsNone) {
  const std::array<std::byte, flight_io::kMissionCellBytes> zeros{};
  auto decoded = flight_io::decode_mission_record(zeros);
  ASSERT_TRUE(decoded.has_value());
  EXPECT_FALSE(decoded->has_value());
}

TEST_F(SetpointNodeTest, MissionRecord_CursorOffThePath_Refused) {
  auto m = flight_io::mission_params(flight_io::Params::from_table({}));
  ASSERT_TRUE(m);
  auto bytes = flight_io::encode_mission_record(
      flight_io::MissionRecord{.mission = *m, .cursor = {.segment = m->waypoints.size(), .tau = 0}, .done = false});
  EXPECT_FALSE(flight_io::decode_mission_record(bytes).has_value());
}

}  // namespace
}  // namespace rejuv::services
