// The mission path and the setpoint generator of `gen_set_point` (§IV-A, §IV-B, docs/design.md §8).
//
// The mission is an ordered list of waypoints; the desired path is the polyline through them. The setpoint
// x_sp is a hover state on that path (position and yaw, everything else 0). The update rule of §IV-A: when the
// estimate is in E(ρ_s, x_sp), move x_sp toward the next waypoint as far as keeps x̂ ∈ E(ρ_M, x_sp'). On a
// straight segment x_sp' = x_sp + t d is affine in the step t, so ‖x̂ − x_sp'‖²_P = c − 2 b t + a t² is a convex
// quadratic and the largest admissible t has a closed form (exact, where a bisection would only approach it).
// One update never passes a waypoint: the next update starts on the next segment.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/flight/ellipsoid.hpp"
#include "rejuv/flight/hover_model.hpp"

namespace rejuv::flight {

struct PathWaypoint {
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  double yaw_rad = 0;
};

enum class PathError : std::uint8_t { Empty, NotFinite };
struct PathFailure {
  PathError kind;
  std::string message;
};

// The polyline through the waypoints; immutable once made (shared by every copy of the generator).
class WaypointPath {
 public:
  [[nodiscard]] static Result<WaypointPath, PathFailure> make(std::vector<PathWaypoint> waypoints);

  [[nodiscard]] std::span<const PathWaypoint> waypoints() const { return waypoints_; }
  [[nodiscard]] std::size_t segment_count() const { return waypoints_.size() - 1; }
  // Point of segment i at fraction τ ∈ [0, 1] as a hover setpoint (yaw interpolated along the shorter turn).
  [[nodiscard]] StateVec setpoint_at(std::size_t segment, double tau) const;
  // d x_sp / dτ on segment i: the position change and the (wrapped) yaw change of the whole segment.
  [[nodiscard]] StateVec segment_direction(std::size_t segment) const;
  // Euclidean distance from p_N_m to the polyline (d of Table I, §VI-D), m.
  [[nodiscard]] double distance_to(const Eigen::Vector3d& p_N_m) const;
  [[nodiscard]] double length_m() const { return length_m_; }

 private:
  explicit WaypointPath(std::vector<PathWaypoint> waypoints);
  std::vector<PathWaypoint> waypoints_;
  double length_m_ = 0;
};

// Where the setpoint is on the path: segment index and fraction τ ∈ [0, 1] along it.
struct PathCursor {
  std::size_t segment = 0;
  double tau = 0;
  // A total order along the path (segment + τ), for monotonicity checks.
  [[nodiscard]] double progress() const { return static_cast<double>(segment) + tau; }
};

enum class UpdateOutcome : std::uint8_t {
  Moved,     // x_sp moved forward
  Held,      // x̂ ∉ E(ρ_M, x_sp): no admissible step
  Finished,  // x_sp is already the last waypoint
};
[[nodiscard]] std::string to_string(UpdateOutcome outcome);

// The setpoint generator's state: a small copyable value, part of the software image that a checkpoint
// saves and a rollback restores (§III "Persistent Data": with a checkpoint after every update, x_sp and the
// waypoint index need no persistent storage, §V-B).
class SetpointGenerator {
 public:
  // Starts at the first waypoint.
  explicit SetpointGenerator(std::shared_ptr<const WaypointPath> path);
  // Starts where a kept record says the setpoint was (a cold restart, docs/design.md §7; §III "Persistent data"):
  // nullopt unless the cursor lies on the path (segment < segment_count, τ ∈ [0, 1]; a one-waypoint path: 0, 0).
  [[nodiscard]] static std::optional<SetpointGenerator> resume_at(std::shared_ptr<const WaypointPath> path,
                                                                  PathCursor cursor);

  [[nodiscard]] const StateVec& setpoint() const { return x_sp_; }
  [[nodiscard]] const PathCursor& cursor() const { return cursor_; }
  [[nodiscard]] const WaypointPath& path() const { return *path_; }
  // The setpoint is the last waypoint.
  [[nodiscard]] bool finished() const;
  // Index of the waypoint the setpoint is heading to (the last one once finished).
  [[nodiscard]] std::size_t target_waypoint() const;

  // The update rule of §IV-A with margin: keeps ‖x̂ − x_sp'‖²_P ≤ (1 − 1e−9) ρ_M².
  UpdateOutcome update(const StateVec& x_hat, const SafetyEllipsoid& ellipsoid, double rho_M);

 private:
  std::shared_ptr<const WaypointPath> path_;
  PathCursor cursor_;
  StateVec x_sp_ = StateVec::Zero();
};

}  // namespace rejuv::flight
