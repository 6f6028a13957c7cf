#include "rejuv/services/gen_set_point/setpoint_node.hpp"

#include <cmath>
#include <string>
#include <utility>

namespace rejuv::services {

namespace {

bool same_mission(const flight_io::MissionSpec& a, const flight_io::MissionSpec& b) {
  if (a.acceptance_radius_m != b.acceptance_radius_m || a.waypoints.size() != b.waypoints.size()) {
    return false;
  }
  for (std::size_t i = 0; i < a.waypoints.size(); ++i) {
    if (a.waypoints[i].p_N_m != b.waypoints[i].p_N_m || a.waypoints[i].yaw_rad != b.waypoints[i].yaw_rad) {
      return false;
    }
  }
  return true;
}

}  // namespace

SetpointNode::SetpointNode(const flight::SafetyEllipsoid& ellipsoid,
                           const flight_io::TrackingParams& tracking)
    : ellipsoid_(ellipsoid), tracking_(tracking) {}

Result<void, flight_io::InputFailure> SetpointNode::on_mission(const rejuv_msg_MissionWaypoints& message) {
  auto mission = flight_io::mission_from_message(message);
  if (!mission) return fail(std::move(mission.error()));
  if (restored_) return {};
  if (mission_ && same_mission(*mission_, *mission)) return {};
  auto path = flight::WaypointPath::make(mission->waypoints);
  if (!path) {
    return fail(flight_io::InputFailure{
        .kind = flight_io::InputError::OutOfRange, .where = "mission", .message = path.error().message});
  }
  path_ = std::make_shared<const flight::WaypointPath>(std::move(*path));
  generator_.emplace(path_);
  mission_ = std::move(*mission);
  next_check_ = Nanos{0};
  hold_until_ = Nanos{0};
  done_at_.reset();
  changed(flight_io::time_of(message.timestamp_ns));
  return {};
}

Result<void, flight_io::InputFailure> SetpointNode::restore(const flight_io::MissionRecord& record, Nanos now) {
  auto path = flight::WaypointPath::make(record.mission.waypoints);
  if (!path) {
    return fail(flight_io::InputFailure{
        .kind = flight_io::InputError::OutOfRange, .where = "mission record", .message = path.error().message});
  }
  auto shared = std::make_shared<const flight::WaypointPath>(std::move(*path));
  auto generator = flight::SetpointGenerator::resume_at(shared, record.cursor);
  if (!generator) {
    return fail(flight_io::InputFailure{.kind = flight_io::InputError::OutOfRange,
                                        .where = "mission record.cursor",
                                        .message = "expected a point on the mission's path"});
  }
  path_ = std::move(shared);
  generator_ = std::move(*generator);
  mission_ = record.mission;
  next_check_ = Nanos{0};
  hold_until_ = Nanos{0};
  done_at_ = record.done ? std::optional<Nanos>(now) : std::nullopt;
  restored_ = true;
  changed(now);
  return {};
}

Result<SetpointNode::UploadOutcome, flight_io::InputFailure> SetpointNode::apply_upload(
    const flight_io::MissionSpec& upload, Nanos now) {
  if (upload.waypoints.empty() || upload.waypoints.size() + 1 > flight_io::kMaxWaypoints) {
    return fail(flight_io::InputFailure{.kind = flight_io::InputError::OutOfRange,
                                        .where = "mission upload.count",
                                        .message = "expected 1 to " + std::to_string(flight_io::kMaxWaypoints - 1) +
                                                   " waypoints (the path starts at the current setpoint)"});
  }
  if (!generator_ || !mission_) return UploadOutcome::Unchanged;
  // The mission flown after an upload is [x_sp then] + the upload: the same upload again (a retransmission
  // whose ack was lost, or the cell read at the next update) changes nothing, also after a cold restart.
  flight_io::MissionSpec tail{.waypoints = {}, .acceptance_radius_m = mission_->acceptance_radius_m,
                              .from_defaults = false};
  if (mission_->waypoints.size() > 1) tail.waypoints.assign(mission_->waypoints.begin() + 1, mission_->waypoints.end());
  if (same_mission(tail, upload)) return UploadOutcome::Unchanged;
  const flight::StateVec& x_sp = generator_->setpoint();
  flight_io::MissionSpec flown{.waypoints = {}, .acceptance_radius_m = upload.acceptance_radius_m,
                               .from_defaults = false};
  flown.waypoints.push_back(flight::PathWaypoint{.p_N_m = x_sp.segment<3>(flight::idx::kPos),
                                                 .yaw_rad = x_sp[flight::idx::kYaw]});
  flown.waypoints.insert(flown.waypoints.end(), upload.waypoints.begin(), upload.waypoints.end());
  auto path = flight::WaypointPath::make(flown.waypoints);
  if (!path) {
    return fail(flight_io::InputFailure{
        .kind = flight_io::InputError::OutOfRange, .where = "mission upload", .message = path.error().message});
  }
  path_ = std::make_shared<const flight::WaypointPath>(std::move(*path));
  generator_.emplace(path_);
  mission_ = std::move(flown);
  done_at_.reset();
  changed(now);
  return UploadOutcome::Applied;
}

std::optional<flight_io::MissionRecord> SetpointNode::record() const {
  if (!generator_ || !mission_) return std::nullopt;
  return flight_io::MissionRecord{.mission = *mission_, .cursor = generator_->cursor(), .done = done_at_.has_value()};
}

Result<void, flight_io::InputFailure> SetpointNode::on_state(const rejuv_msg_VehicleStateEstimate& message) {
  auto x_hat = flight_io::state_from_message(message);
  if (!x_hat) return fail(std::move(x_hat.error()));
  x_hat_ = *x_hat;
  if (!generator_) return {};
  const Nanos now = flight_io::time_of(message.timestamp_ns);
  if (tracking_.sr == flight::SrSwitch::Off) track_without_sr(now);
  check_completion(now);
#if defined(REJUV_ATTACK_HOOKS)
  // ==== ATTACK HOOK POINT ====
  if (attack_hook_) {
    if (auto offset = attack_hook_(now)) {
      attack_offset_ = *offset;
      changed(now);
    }
  }
#endif
  return {};
}

void SetpointNode::track_without_sr(Nanos now) {
  // flight/sim SrSimulation track_without_sr, evaluated on each estimate (the simulation evaluates it every
  // physics step; x̂ only changes per IMU tick, so with check_period ≤ the IMU period the two agree).
  if (now < next_check_) return;
  const Nanos period = to_nanos(tracking_.check_period);
  next_check_ += ((now - next_check_) / period + 1) * period;  // the next check strictly after now
  if (now < hold_until_) return;
  const double rho_s = tracking_.rho_s;
  if (ellipsoid_.V(*x_hat_, generator_->setpoint()) < rho_s * rho_s) {
    if (generator_->update(*x_hat_, ellipsoid_, tracking_.rho_M) == flight::UpdateOutcome::Moved) {
      hold_until_ = now + to_nanos(tracking_.t_min);
      changed(now);
    }
  }
}

void SetpointNode::check_completion(Nanos now) {
  // flight/sim SrSimulation check_completion.
  if (done_at_ || !generator_->finished()) return;
  const Eigen::Vector3d goal = path_->waypoints().back().p_N_m;
  if ((x_hat_->segment<3>(flight::idx::kPos) - goal).norm() <= mission_->acceptance_radius_m) {
    done_at_ = now;
    changed(now);
  }
}

SetpointNode::RequestOutcome SetpointNode::on_update_request(const rejuv_msg_SetpointUpdateRequest& message) {
  if (tracking_.sr == flight::SrSwitch::Off || !generator_ || !x_hat_) return RequestOutcome::Ignored;
  const double rho_M = std::isfinite(message.rho_m) && message.rho_m > 0.0 && message.rho_m <= 1.0
                           ? message.rho_m
                           : tracking_.rho_M;
  switch (generator_->update(*x_hat_, ellipsoid_, rho_M)) {
    case flight::UpdateOutcome::Moved:
      changed(flight_io::time_of(message.timestamp_ns));
      return RequestOutcome::Moved;
    case flight::UpdateOutcome::Held: return RequestOutcome::Held;
    case flight::UpdateOutcome::Finished: return RequestOutcome::Finished;
  }
  return RequestOutcome::Held;
}

void SetpointNode::changed(Nanos now) {
  changed_at_ = now;
}

std::optional<rejuv_msg_Setpoint> SetpointNode::take_changed() {
  if (!changed_at_ || !generator_) return std::nullopt;
  flight::StateVec x_sp = generator_->setpoint();
#if defined(REJUV_ATTACK_HOOKS)
  x_sp += attack_offset_;
#endif
  const rejuv_msg_Setpoint m =
      flight_io::setpoint_message(x_sp, *changed_at_,
                                  static_cast<std::uint32_t>(generator_->target_waypoint()), mission_done());
  changed_at_.reset();
  return m;
}

}  // namespace rejuv::services
