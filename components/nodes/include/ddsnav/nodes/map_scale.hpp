#pragma once
// The mapper's resolution and range for a scenario, when the user leaves them unset (docs/world-model.md,
// "The map's scale"). The mapper does not see the sensor; it reads the same scenario the simulator does and
// follows the simulator's default sensor (sim::defaultMaxRange):
//
//   resolution = max(0.1 m, robot_radius / 5)   a mapped surface is up to a voxel diagonal nearer than the
//                                               true one: a fifth of the robot radius keeps that small
//                                               against the robot, never finer than the 0.1 m of the yard
//                in 3-D at least min(sensor range / 300, robot_radius / 2): voxels coarse enough to map
//                the whole range, never coarser than half the robot radius
//   max_range  = min(sensor range, N voxels)    the whole sensor range, with the ray casting per beam
//                                               bounded to N voxels: 300 in 3-D (the cost of 30 m at 0.1 m),
//                                               1 000 in 2-D (a scanner has a few hundred beams)
//
// On every 2-D world with robot_radius <= 0.5 m this is 0.1 m and the scanner's whole range up to 100 m
// (bugtrap_1.0, stunnel_1.0: 65.9 m); gart_terrain_3d (65.9 m lidar) maps at 0.22 m out to 65.9 m; at sea scale
// (auv_coastal: robot radius 2 m, a 200 m sonar) 0.4 m and the sonar's 200 m.

#include <ddsnav/planner/scenario.hpp>

namespace ddsnav::nodes {

struct MapScale {
  double resolution = 0.1;  // m, leaf size of the octree
  double max_range = 30.0;  // m, beams are cut here
};

// The rule above; `sensor_range` is the simulator's range for the scenario (sim::defaultMaxRange).
MapScale mapScaleFor(const planner::Scenario& scenario, double sensor_range);

// The world model's lengths that follow the robot's size when left unset (docs/world-model.md, "Lengths that
// follow the robot"). They were set on the paper's 110 m worlds (robot radius 0.5 m) and kept there; a world
// ten times smaller (stunnel_small_0.5: a 0.5 m corridor, radius 0.1 m) must not be read with the same metres —
// a 1 m unseen margin closes every corridor in it, and a 6 m scanner never sees a 10 m wall whole, so every wall
// became a chain of ellipses that closed the corridor. None grows past its value on the paper's worlds.
//
//   structure_extent_m     = min(10 m, 25 r)   perception: a longer cluster is structure, left to the map
//   unknown_margin_m       = min(1 m, 2 r)     planner and tracker: unseen space this close to a seen surface
//   hidden_continuation_m  = min(15 m, 30 r)   planner: a seen surface continued into space hidden from the vehicle
double defaultStructureExtent(const planner::Scenario& scenario);
double defaultUnknownMargin(const planner::Scenario& scenario);
double defaultHiddenContinuation(const planner::Scenario& scenario);

}  // namespace ddsnav::nodes
