#include "ddsnav/sim/city_block.hpp"

#include <random>

namespace ddsnav::sim {
namespace {

planner::Obstacle box(double x, double y, double z, double sx, double sy, double sz, double yaw = 0.0) {
  planner::Obstacle o;
  o.type = planner::ObstacleType::Box;
  o.center = {x, y, z};
  o.size = {sx, sy, sz};
  o.yaw = yaw;
  return o;
}

planner::Obstacle ellipsoid(double x, double y, double z, double a, double b, double c, double yaw) {
  planner::Obstacle o;
  o.type = planner::ObstacleType::Ellipsoid;
  o.center = {x, y, z};
  o.semi_axes = {a, b, c};
  o.yaw = yaw;
  return o;
}

}  // namespace

planner::Scenario makeCityBlock(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };

  planner::Scenario s;
  s.name = "city_block";
  s.dimensions = 3;
  s.bounds_min = {-60, -60, 0};
  s.bounds_max = {60, 60, 30};
  s.robot_radius = 0.5;
  s.start = {-50, 0, 1.8};
  s.goal = {50, 0, 1.8};
  s.goal_radius = 2.0;

  for (int side : {-1, 1}) {
    // Building fronts along the street, separated by alleys.
    for (double x = -58.0; x < 56.0;) {
      const double length = uniform(8.0, 20.0), depth = uniform(10.0, 25.0), height = uniform(6.0, 25.0);
      const double front = uniform(11.0, 14.0);
      s.obstacles.push_back(box(x + 0.5 * length, side * (front + 0.5 * depth), 0.5 * height, length, depth, height));
      x += length + uniform(2.0, 5.0);
    }
    // Parked cars along the kerb, some slightly rotated.
    for (double x = -55.0; x < 55.0;) {
      s.obstacles.push_back(box(x, side * 6.0, 0.75, 4.5, 1.8, 1.5, uniform(-0.1, 0.1)));
      x += uniform(6.0, 12.0);
    }
    // Trees (trunk + crown) and poles on the sidewalk.
    for (double x = -54.0; x < 54.0; x += uniform(9.0, 14.0)) {
      s.obstacles.push_back(box(x, side * 9.0, 1.5, 0.4, 0.4, 3.0));
      s.obstacles.push_back(ellipsoid(x, side * 9.0, 4.5, uniform(1.5, 2.5), uniform(1.5, 2.5), 2.0, uniform(0, 3)));
    }
    for (double x = -50.0; x < 50.0; x += uniform(15.0, 25.0))
      s.obstacles.push_back(box(x + 4.0, side * 8.0, 2.5, 0.2, 0.2, 5.0));
  }
  // Pedestrians on the street.
  for (int i = 0; i < 8; ++i)
    s.obstacles.push_back(ellipsoid(uniform(-40, 40), uniform(-4, 4), 0.9, 0.3, 0.25, 0.9, uniform(0, 3)));
  return s;
}

}  // namespace ddsnav::sim
