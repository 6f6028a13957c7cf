#include "rejuv/flight/setpoint.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rejuv/flight/detail/printf.hpp"

namespace rejuv::flight {

std::string to_string(UpdateOutcome outcome) {
  switch (outcome) {
    case UpdateOutcome::Moved: return "moved";
    case UpdateOutcome::Held: return "held";
    case UpdateOutcome::Finished: return "finished";
  }
  return "unknown";
}

Result<WaypointPath, PathFailure> WaypointPath::make(std::vector<PathWaypoint> waypoints) {
  if (waypoints.empty()) {
    return fail(PathFailure{PathError::Empty, "a mission needs at least one waypoint"});
  }
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    if (!waypoints[i].p_N_m.allFinite() || !std::isfinite(waypoints[i].yaw_rad)) {
      return fail(PathFailure{PathError::NotFinite, detail::printf_string("waypoint %zu is not finite", i)});
    }
  }
  return WaypointPath(std::move(waypoints));
}

WaypointPath::WaypointPath(std::vector<PathWaypoint> waypoints) : waypoints_(std::move(waypoints)) {
  // A single waypoint is a path of one (degenerate) segment from it to itself: hover there.
  if (waypoints_.size() == 1) waypoints_.push_back(waypoints_.front());
  for (std::size_t i = 0; i + 1 < waypoints_.size(); ++i) {
    length_m_ += (waypoints_[i + 1].p_N_m - waypoints_[i].p_N_m).norm();
  }
}

StateVec WaypointPath::segment_direction(std::size_t segment) const {
  const PathWaypoint& a = waypoints_[segment];
  const PathWaypoint& b = waypoints_[segment + 1];
  StateVec d = StateVec::Zero();
  d.segment<3>(idx::kPos) = b.p_N_m - a.p_N_m;
  d[idx::kYaw] = wrap_angle_rad(b.yaw_rad - a.yaw_rad);
  return d;
}

StateVec WaypointPath::setpoint_at(std::size_t segment, double tau) const {
  const PathWaypoint& a = waypoints_[segment];
  StateVec x = hover_setpoint(a.p_N_m, a.yaw_rad) + tau * segment_direction(segment);
  x[idx::kYaw] = wrap_angle_rad(x[idx::kYaw]);
  return x;
}

double WaypointPath::distance_to(const Eigen::Vector3d& p_N_m) const {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < waypoints_.size(); ++i) {
    const Eigen::Vector3d a = waypoints_[i].p_N_m;
    const Eigen::Vector3d ab = waypoints_[i + 1].p_N_m - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((p_N_m - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (p_N_m - (a + t * ab)).norm());
  }
  return best;
}

SetpointGenerator::SetpointGenerator(std::shared_ptr<const WaypointPath> path) : path_(std::move(path)) {
  x_sp_ = path_->setpoint_at(0, 0.0);
}

std::optional<SetpointGenerator> SetpointGenerator::resume_at(std::shared_ptr<const WaypointPath> path,
                                                              PathCursor cursor) {
  const std::size_t segments = path->segment_count();
  const bool on_path = segments == 0 ? cursor.segment == 0 && cursor.tau == 0.0
                                     : cursor.segment < segments && cursor.tau >= 0.0 && cursor.tau <= 1.0;
  if (!on_path) return std::nullopt;  // also a NaN τ
  SetpointGenerator g(std::move(path));
  g.cursor_ = cursor;
  g.x_sp_ = g.path_->setpoint_at(cursor.segment, cursor.tau);
  return g;
}

bool SetpointGenerator::finished() const {
  return cursor_.segment + 1 == path_->segment_count() && cursor_.tau >= 1.0;
}

std::size_t SetpointGenerator::target_waypoint() const {
  return std::min(cursor_.segment + 1, path_->waypoints().size() - 1);
}

UpdateOutcome SetpointGenerator::update(const StateVec& x_hat, const SafetyEllipsoid& ellipsoid, double rho_M) {
  // A segment that is complete hands over to the next one (same point: x_sp does not jump).
  if (cursor_.tau >= 1.0 && cursor_.segment + 1 < path_->segment_count()) {
    cursor_ = PathCursor{cursor_.segment + 1, 0.0};
  }
  if (finished()) return UpdateOutcome::Finished;

  const StateVec d = path_->segment_direction(cursor_.segment);
  const StateVec e0 = state_error(x_hat, x_sp_);
  const StateMat& P = ellipsoid.P();
  // ‖e0 − t d‖²_P = c − 2 b t + a t² ≤ ρ², t ∈ [0, 1 − τ].
  const double a = d.dot(P * d);
  const double b = d.dot(P * e0);
  const double c = e0.dot(P * e0);
  const double rho2 = (1.0 - 1e-9) * rho_M * rho_M;
  const double remaining = 1.0 - cursor_.tau;
  double t = 0.0;
  if (a <= 0.0) {
    t = remaining;  // a zero-length, zero-turn segment: nothing to move along
  } else {
    if (c > rho2) return UpdateOutcome::Held;
    const double disc = std::max(0.0, b * b - a * (c - rho2));
    t = std::min(remaining, (b + std::sqrt(disc)) / a);
  }
  if (t <= 0.0) return UpdateOutcome::Held;
  cursor_.tau = std::min(1.0, cursor_.tau + t);
  x_sp_ = path_->setpoint_at(cursor_.segment, cursor_.tau);
  return UpdateOutcome::Moved;
}

}  // namespace rejuv::flight
