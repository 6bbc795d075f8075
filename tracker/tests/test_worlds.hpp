#pragma once
// Small hand-made worlds for the tracker tests.

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"

#include <memory>
#include <string>
#include <vector>

namespace ddsnav::tracker::testing {

// A 2-D world of the given size with the obstacles given as scenario-format YAML list entries.
inline planner::Scenario scenario2d(double size, double robot_radius, const std::string& obstacles_yaml,
                                    double v_max = 1.0, double omega_max = 1.0) {
  const std::string text = "name: test\ndimensions: 2\nbounds: {min: [0, 0], max: [" + std::to_string(size) + ", " +
                           std::to_string(size) + "]}\nrobot_radius: " + std::to_string(robot_radius) +
                           "\nstart: [1, 1]\ngoal: [2, 2]\ngoal_radius: 0.5\nvehicle: {model: unicycle, v_max: " +
                           std::to_string(v_max) + ", omega_max: " + std::to_string(omega_max) +
                           ", dt: 1.0}\nobstacles:" + (obstacles_yaml.empty() ? " []\n" : "\n" + obstacles_yaml);
  return planner::parseScenario(text, "test-world");
}

inline std::vector<planner::State> pathOf(std::initializer_list<planner::Vec3> points) {
  std::vector<planner::State> path;
  for (const auto& p : points) path.push_back({p, 0.0});
  return path;
}

}  // namespace ddsnav::tracker::testing
