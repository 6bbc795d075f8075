#include "ddsnav/tracker/closed_loop.hpp"

#include <cmath>

namespace ddsnav::tracker {

ClosedLoopResult runClosedLoop(const Trajectory& trajectory, const ClosedLoopConfig& config,
                               const planner::CollisionWorld* world) {
  TrajectoryTracker tracker(trajectory, config.vehicle.limits, config.tracker);
  VehicleState start = config.start_motion.value_or(VehicleState{});
  start.time = 0.0;
  start.position = trajectory.samples.front().position;
  start.heading = trajectory.samples.front().heading;
  UnicycleVehicle vehicle(config.vehicle, start);

  ClosedLoopResult result;
  result.track.push_back(vehicle.state());
  const double timeout = config.timeout_factor * trajectory.duration() + 10.0;
  while (vehicle.state().time < timeout) {
    const VehicleCommand cmd = tracker.update(vehicle.state(), config.control_dt);
    if (tracker.status().goal_reached) break;
    const double before = vehicle.state().heading;
    const VehicleState& now = vehicle.step(cmd, config.control_dt);
    result.max_heading_step = std::max(result.max_heading_step, std::abs(wrapAngle(now.heading - before)));
    result.track.push_back(now);
    if (world && !world->isFree(now.position)) ++result.track_states_in_collision;
  }
  result.goal_reached = tracker.status().goal_reached;
  result.status = tracker.status();
  result.time = vehicle.state().time;
  return result;
}

}  // namespace ddsnav::tracker
