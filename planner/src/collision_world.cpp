#include "ddsnav/planner/collision_world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

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

bool segmentClearanceAtLeast(const CollisionWorld& world, const Vec3& a, const Vec3& b, double required) {
  if (required <= 0.0) return true;
  const double length = (b - a).norm();
  const Vec3 dir = length > 0 ? Vec3((b - a) / length) : Vec3::Zero();
  const double min_step = world.checkResolution();
  for (double t = 0.0;; ) {
    const double c = world.clearance(a + std::min(t, length) * dir);
    if (c < required) return false;
    if (t >= length) return true;
    t = std::min(length, t + std::max(c - required, min_step));
  }
}

namespace {

// Whether a straight free segment `length` long leaves q along one of the lattice's directions (8 in 2-D, 26 in 3-D).
bool leadsOut(const CollisionWorld& world, const Vec3& q, double length) {
  const bool flat = world.dimensions() == 2;
  for (int k = flat ? 0 : -1; k <= (flat ? 0 : 1); ++k)
    for (int j = -1; j <= 1; ++j)
      for (int i = -1; i <= 1; ++i) {
        if (i == 0 && j == 0 && k == 0) continue;
        if (world.isSegmentFree(q, q + Vec3(i, j, k).normalized() * length)) return true;
      }
  return false;
}

}  // namespace

std::optional<Vec3> nearestFreePosition(const CollisionWorld& world, const Vec3& p, double max_distance, double step,
                                        double wanted_clearance, double escape_length) {
  if (!p.allFinite()) throw std::invalid_argument("nearestFreePosition: the position must be finite");
  if (!std::isfinite(max_distance) || max_distance < 0.0) throw std::invalid_argument("nearestFreePosition: max_distance must be finite and >= 0");
  if (!std::isfinite(step) || !(step > 0.0)) throw std::invalid_argument("nearestFreePosition: step must be finite and > 0");
  if (!std::isfinite(wanted_clearance) || wanted_clearance < 0.0)
    throw std::invalid_argument("nearestFreePosition: wanted_clearance must be finite and >= 0");
  if (!std::isfinite(escape_length) || escape_length < 0.0)
    throw std::invalid_argument("nearestFreePosition: escape_length must be finite and >= 0");
  if (world.isFree(p)) return p;
  const bool flat = world.dimensions() == 2;
  const int n = static_cast<int>(std::floor(max_distance / step));
  const double side = 2.0 * n + 1.0;
  if ((flat ? side * side : side * side * side) > 1e6) throw std::invalid_argument("nearestFreePosition: more than 1e6 lattice points");
  struct Offset {
    double distance;
    Vec3 d;
  };
  std::vector<Offset> offsets;
  for (int k = flat ? 0 : -n; k <= (flat ? 0 : n); ++k)
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        const Vec3 d(i * step, j * step, k * step);
        const double distance = d.norm();
        if (distance > 0.0 && distance <= max_distance) offsets.push_back({distance, d});
      }
  // Nearest first; among equals the lattice order above, so the answer does not depend on the sort.
  std::stable_sort(offsets.begin(), offsets.end(), [](const Offset& a, const Offset& b) { return a.distance < b.distance; });
  // A free pocket inside what the world blocks (a hole in a map's widened terrain) is no way out: at most this many
  // free positions are tested for a way out, 26 segments each, so that a start buried deep costs milliseconds.
  constexpr int kMaxEscapeTests = 100;
  int escape_tests = 0;
  std::optional<Vec3> nearest_free;   // the last resort: free, but neither clear enough nor known to lead out
  std::optional<Vec3> nearest_clear;  // clear enough, not known to lead out
  std::optional<Vec3> nearest_out;    // leading out, not clear enough
  double give_up_at = max_distance;
  for (const Offset& o : offsets) {
    if (o.distance > give_up_at) break;
    const Vec3 q = p + o.d;
    if (!world.isFree(q)) continue;
    if (!nearest_free) nearest_free = q;
    const bool clear = wanted_clearance <= 0.0 || world.clearance(q) >= wanted_clearance;
    if (escape_length > 0.0) {
      if (escape_tests++ >= kMaxEscapeTests) break;
      if (!leadsOut(world, q, escape_length)) {
        if (clear && !nearest_clear) nearest_clear = q;
        continue;
      }
    }
    if (clear) return q;
    if (!nearest_out) nearest_out = q, give_up_at = std::min(max_distance, o.distance + wanted_clearance + 1e-9);
  }
  return nearest_out ? nearest_out : nearest_clear ? nearest_clear : nearest_free;
}

}  // namespace ddsnav::planner
