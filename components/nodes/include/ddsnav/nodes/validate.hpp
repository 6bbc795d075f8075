#pragma once
// Checks for messages that arrive from other processes, run once where they enter a component (the
// WorldSource callbacks), so a malformed message is dropped with a warning instead of throwing later,
// deep inside a planner or tracker callback.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <Eigen/Core>

#include <chrono>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace ddsnav::nodes {

// Empty when every obstacle of `array` can be planned around: header frame `frame`, finite centre,
// semi-axes, orientation and covariance, semi-axes > 0 (x and y only for a planar array, whose z is 0),
// a quaternion of non-zero norm. Otherwise what is wrong with the first bad obstacle, e.g.
// "obstacle 2 (id 7): semi-axis y is -1, expected > 0". An empty `frame` accepts any frame.
std::string checkObstacleArray(const msg::ObstacleArray& array, const std::string& frame);

// Empty when `map` is in frame `frame`, has a positive finite resolution and its bytes are a binary
// OctoMap octree the planner can build a world of for `scenario`; otherwise what is wrong.
std::string checkOccupancyMap(const msg::OccupancyMap& map, const std::string& frame, const planner::Scenario& scenario);
// The same checks, keeping the world they build (with `options`: the unknown-space policy) instead of
// throwing it away: `world` is set exactly when `error` is empty.
struct CheckedMap {
  std::string error;
  std::unique_ptr<planner::CollisionWorld> world;
};
CheckedMap buildOccupancyMap(const msg::OccupancyMap& map, const std::string& frame, const planner::Scenario& scenario,
                             const planner::OctoMapWorldOptions& options);

// Empty when `state` is in frame `frame` (empty: any) and every number in it (position, heading,
// velocity, yaw rate) is finite; otherwise the first bad field, e.g. "position.z is nan".
std::string checkVehicleState(const msg::VehicleState& state, const std::string& frame);

// Empty when every state of `path` is finite (x, y, z, heading) and a solved path has at least one state;
// otherwise what is wrong, e.g. "state 3: y is inf". The tracker refuses such an answer as a failed plan.
std::string checkPath(const msg::Path& path);

// Empty when every number of `trajectory` (sample positions, headings, velocities, yaw rates) is finite;
// otherwise the first bad field, e.g. "sample 12: position.y is nan".
std::string checkTrajectory(const msg::Trajectory& trajectory);

// Empty when every number of `status` is finite and progress is in [0, 1]; otherwise the first bad field.
std::string checkTrackingStatus(const msg::TrackingStatus& status);

// Empty when `request` can be planned in `scenario`'s world: frame `frame` (empty: any); start and goal
// finite and inside the scenario's bounds (z = 0 in a 2-D world); finite heading; goal_radius in
// (0, the bounds' diagonal]; time_budget_s positive and finite (the planner then caps it at its
// max_time_budget_s). Otherwise the first bad field with its value and the bound, e.g.
// "goal.z = 1e+300 is outside the planning bounds [0, 0] (a 2-D world)".
std::string checkPlanRequest(const msg::PlanRequest& request, const planner::Scenario& scenario, const std::string& frame);

// A request for a shorter route while the vehicle flies on (the tracker's reason "shorter_route: ..."): its answer is
// flown only when it reaches the goal sooner, so it is not taken for the path being flown (the planner's
// previous_path_bias guide).
bool asksForAShorterRoute(const msg::PlanRequest& request);

// The samples one component drops on one topic: counted, and logged as warnings that name the topic and
// what was wrong — the first one, then at most one per second carrying the running count, so a stream of
// bad samples at 50 Hz neither floods the log nor goes unnoticed. Thread-safe.
class DroppedSamples {
 public:
  explicit DroppedSamples(std::string topic, std::string kept = "keeping the last good sample");
  // Counts one dropped sample; `what` says what was wrong with it (e.g. checkVehicleState's answer).
  void drop(const std::string& what);
  std::size_t count() const;

 private:
  const std::string topic_, kept_;
  mutable std::mutex mutex_;
  std::size_t count_ = 0;
  std::chrono::steady_clock::time_point last_warning_{};
};

// True when every finite point lies in z = 0 (a planar scanner's cloud). Non-finite points are ignored:
// a scanner reports "no return" beams as NaN/inf, and they say nothing about the cloud's shape.
bool isPlanarCloud(const std::vector<Eigen::Vector3f>& points);

}  // namespace ddsnav::nodes
