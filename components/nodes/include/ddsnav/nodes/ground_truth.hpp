#pragma once
// What the monitor judges on the scenario's true geometry (it is the one process that knows it): whether
// the goal can be reached at all, and how close the driven track came to the true obstacles. No DDS.

#include <ddsnav/planner/scenario.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace ddsnav::nodes {

struct GoalFeasibility {
  bool feasible = true;
  std::string why;  // when not feasible: what makes the goal unreachable, naming the places
};

// The mission is infeasible when the start state is in collision, when no state within goal_radius of the
// goal is free (the goal inside an obstacle), or when free space does not connect the start to the goal
// region. Connectivity is decided on a grid of at most `max_cells` cells whose centres are checked with the
// robot radius shrunk by one cell diagonal, so the grid's free space contains every truly free path: an
// "unreachable" answer is certain, a "feasible" one is not a proof (a passage narrower than the robot may
// still look open).
GoalFeasibility checkGoalFeasible(const planner::Scenario& scenario, std::size_t max_cells = std::size_t{1} << 20);

// The smallest clearance of the robot (robot radius subtracted, as CollisionWorld::clearance) along the
// driven track to what makes a state invalid in the scenario format: its true obstacles and the faces of its
// bounds (the robot lies inside them); negative when the track touched one or left the bounds; nullopt for an
// empty track. A world without obstacles has the bounds' clearance: a run there has a number too.
std::optional<double> minTrueClearance(const planner::Scenario& scenario, const std::vector<planner::Vec3>& track);

// The same, with where along the track it happened (the report names the place, so a touch can be found).
struct ClosestApproach {
  double clearance_m = 0.0;
  std::size_t index = 0;  // into the track
  bool to_bounds = false;  // nearest to a face of the bounds, not to an obstacle
};
std::optional<ClosestApproach> closestApproach(const planner::Scenario& scenario, const std::vector<planner::Vec3>& track);

}  // namespace ddsnav::nodes
