// The example's algorithm, without DDS: which obstacle is nearest to a point. The component
// (closest_obstacle_main.cpp) converts messages to these types, calls it and publishes the answer.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

namespace example {

struct Point {
  double x = 0, y = 0, z = 0;
};

// An obstacle as perception reports it, reduced to what the distance needs.
struct Obstacle {
  std::uint32_t id = 0;
  Point centre;
  double largest_semi_axis = 0;  // m
};

struct Nearest {
  std::uint32_t id = 0;
  Point centre;
  double distance = 0;  // m, from the point to the centre less largest_semi_axis, never below 0
};

// The obstacle with the smallest distance from `from`; the lower id on a tie; nullopt when there is none.
std::optional<Nearest> closestObstacle(const std::vector<Obstacle>& obstacles, const Point& from);

}  // namespace example
