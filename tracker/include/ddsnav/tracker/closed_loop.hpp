#pragma once
// Smoother output + tracker + vehicle model in one process, for tests and benchmarks: drives the simulated
// unicycle along a trajectory and records what happened. (The distributed version is the sim and tracker
// components talking over the bus.)

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/tracker/tracker.hpp"
#include "ddsnav/tracker/vehicle.hpp"

#include <optional>
#include <vector>

namespace ddsnav::tracker {

struct ClosedLoopConfig {
  double control_dt = 0.05;      // s between control updates (the vehicle holds each command that long)
  double timeout_factor = 2.0;   // give up after timeout_factor * duration + 10 s
  VehicleConfig vehicle;         // limits, acceleration limits, noise
  TrackerConfig tracker;
  // The vehicle's speeds at the first sample (v, omega, vz; a replan's moving start); at rest when not given.
  std::optional<VehicleState> start_motion;
};

struct ClosedLoopResult {
  bool goal_reached = false;
  double time = 0.0;                    // s driven
  TrackingStatus status;                // the tracker's final status (running mean / max errors)
  std::vector<VehicleState> track;      // the vehicle state after every step
  std::size_t track_states_in_collision = 0;  // driven states whose robot disc is not free (when a world is given)
  double max_heading_step = 0.0;        // rad, largest heading change of the vehicle in one control step
};

// Starts the vehicle at the trajectory's first sample (heading: `initial_heading`, else the first sample's).
ClosedLoopResult runClosedLoop(const Trajectory& trajectory, const ClosedLoopConfig& config,
                               const planner::CollisionWorld* world = nullptr);

}  // namespace ddsnav::tracker
