#include "ddsnav/planner/collision_world.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::planner {

bool CollisionWorld::isSegmentFree(const Vec3& a, const Vec3& b) const {
  // Check the far end first: most rejected edges fail there, and it is the cheapest early exit.
  if (!isFree(b)) return false;
  const double length = (b - a).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / checkResolution())));
  for (int i = steps - 1; i >= 0; --i) {
    if (!isFree(a + (b - a) * (static_cast<double>(i) / steps))) return false;
  }
  return true;
}

}  // namespace ddsnav::planner
