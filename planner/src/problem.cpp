#include "ddsnav/planner/planner.hpp"

#include <cmath>

namespace ddsnav::planner {

double startHeading(const Scenario& scenario) {
  const Vec3 to_goal = scenario.goal - scenario.start;
  return scenario.start_heading.value_or(std::atan2(to_goal.y(), to_goal.x()));
}

PlanProblem problemFromScenario(const Scenario& scenario, const CollisionWorld& world) {
  PlanProblem problem;
  problem.world = &world;
  problem.start = State{scenario.start, startHeading(scenario)};
  problem.goal = scenario.goal;
  problem.goal_radius = scenario.goal_radius;
  problem.vehicle = scenario.vehicle;
  return problem;
}

}  // namespace ddsnav::planner
