#include "closest_obstacle.hpp"

#include <algorithm>
#include <cmath>

namespace example {

std::optional<Nearest> closestObstacle(const std::vector<Obstacle>& obstacles, const Point& from) {
  std::optional<Nearest> best;
  for (const Obstacle& o : obstacles) {
    const double to_centre = std::hypot(o.centre.x - from.x, o.centre.y - from.y, o.centre.z - from.z);
    const double distance = std::max(0.0, to_centre - o.largest_semi_axis);
    if (!best || distance < best->distance || (distance == best->distance && o.id < best->id))
      best = Nearest{o.id, o.centre, distance};
  }
  return best;
}

}  // namespace example
