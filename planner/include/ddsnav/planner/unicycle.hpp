#pragma once
// The unicycle's forward extending region R+ (GART paper; the same edge model serves Li-RRT and the
// unicycle mode of RRT/RRT*).
//
// Model: x' = v cos(theta), y' = v sin(theta), theta' = omega, z' = vz, with 0 <= v <= v_max,
// |omega| <= omega_max, |vz| <= vz_max, held for one edge duration dt. A tree edge is the straight chord
// the vehicle may cover in dt: from a parent at heading theta_p, the child lies at horizontal distance
// <= reach = v_max*dt, in a horizontal direction within max_turn = omega_max*dt of theta_p, and (3-D) at
// most max_climb = vz_max*dt above or below. The child's heading is the horizontal direction of the edge
// (or the parent's heading when the edge has no horizontal extent, e.g. a pure climb or a zero step).
//
// All of this is header-only and cheap: the planners call it in their inner loops.

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::planner {

// Angle in (-pi, pi]. Every planner calls this several times per iteration, mostly on a difference of two
// wrapped angles, so inside (-2 pi, 2 pi) it shifts by 2 pi once: the result is exactly std::remainder's (the
// shifted value is exact by Sterbenz's lemma, and |a| = pi stays put as remainder's ties-to-even does) at a
// fraction of its cost.
inline double wrapAngle(double a) {
  constexpr double kPi = std::numbers::pi;
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  if (std::abs(a) < kTwoPi) {
    if (a > kPi) a -= kTwoPi;
    else if (a < -kPi) a += kTwoPi;
  } else {
    a = std::remainder(a, kTwoPi);
  }
  return a <= -kPi ? a + kTwoPi : a;
}

// Horizontal length below which an edge is treated as having no direction (keeps the parent heading).
inline constexpr double kNoDirectionLength = 1e-9;

struct ForwardRegion {
  int dimensions = 2;
  double reach = 0.0;      // v_max * dt, horizontal metres
  double max_turn = 0.0;   // omega_max * dt, radians either side of the parent heading
  double max_climb = 0.0;  // vz_max * dt, metres up or down (3-D only)
};

// Throws std::invalid_argument for non-positive or non-finite limits.
inline ForwardRegion forwardRegion(const VehicleLimits& limits, int dimensions) {
  auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  if (!positive(limits.v_max) || !positive(limits.omega_max) || !positive(limits.dt)) {
    throw std::invalid_argument("unicycle limits need finite v_max > 0, omega_max > 0 and dt > 0");
  }
  if (dimensions == 3 && !(std::isfinite(limits.vz_max) && limits.vz_max >= 0.0)) {
    throw std::invalid_argument("unicycle limits need a finite vz_max >= 0 in 3-D");
  }
  ForwardRegion r;
  r.dimensions = dimensions;
  r.reach = limits.v_max * limits.dt;
  // Turning more than pi in one edge is the same as being able to point anywhere.
  r.max_turn = std::min(limits.omega_max * limits.dt, std::numbers::pi);
  r.max_climb = dimensions == 3 ? limits.vz_max * limits.dt : 0.0;
  return r;
}

// Horizontal heading of the edge from -> to; `fallback` when the edge has no horizontal extent.
inline double edgeHeading(const Vec3& from, const Vec3& to, double fallback) {
  const double dx = to.x() - from.x();
  const double dy = to.y() - from.y();
  if (std::hypot(dx, dy) <= kNoDirectionLength) return fallback;
  return std::atan2(dy, dx);
}

// The child state reached by driving `horizontal_length` metres after turning by `turn` radians
// (both clamped into the region) and climbing `climb` metres (clamped; ignored in 2-D).
inline State driveUnicycle(const State& parent, double turn, double horizontal_length, double climb,
                           const ForwardRegion& region) {
  turn = std::clamp(turn, -region.max_turn, region.max_turn);
  horizontal_length = std::clamp(horizontal_length, 0.0, region.reach);
  climb = region.dimensions == 3 ? std::clamp(climb, -region.max_climb, region.max_climb) : 0.0;
  const double heading = wrapAngle(parent.heading + turn);
  State child;
  child.position = parent.position + Vec3(horizontal_length * std::cos(heading),
                                          horizontal_length * std::sin(heading), climb);
  child.heading = edgeHeading(parent.position, child.position, parent.heading);
  return child;
}

// Turn (signed, radians) needed to point from the parent towards `target`; 0 when target is straight
// above/below or coincident.
inline double turnTowards(const State& parent, const Vec3& target) {
  return wrapAngle(edgeHeading(parent.position, target, parent.heading) - parent.heading);
}

// Steer from `parent` towards `target`: turn as far as allowed towards it, drive min(reach, horizontal
// distance), climb proportionally (the straight line's slope), clamped to max_climb.
// When the target is inside R+(parent) the result is exactly the target.
inline State steerUnicycle(const State& parent, const Vec3& target, const ForwardRegion& region) {
  const Vec3 d = target - parent.position;
  const double horizontal = std::hypot(d.x(), d.y());
  const double turn = turnTowards(parent, target);
  if (horizontal <= region.reach && std::abs(turn) <= region.max_turn &&
      (region.dimensions == 2 || std::abs(d.z()) <= region.max_climb)) {
    State child;
    child.position = target;
    if (region.dimensions == 2) child.position.z() = parent.position.z();
    child.heading = edgeHeading(parent.position, child.position, parent.heading);
    return child;
  }
  const double length = std::min(horizontal, region.reach);
  const double scale = horizontal > region.reach ? region.reach / horizontal : 1.0;
  return driveUnicycle(parent, turn, length, d.z() * scale, region);
}

// Whether `target` lies in R+(parent). `tolerance` absorbs floating-point round-off (metres and radians).
inline bool inForwardRegion(const State& parent, const Vec3& target, const ForwardRegion& region,
                            double tolerance = 1e-6) {
  const Vec3 d = target - parent.position;
  const double horizontal = std::hypot(d.x(), d.y());
  if (horizontal > region.reach + tolerance) return false;
  if (region.dimensions == 3 && std::abs(d.z()) > region.max_climb + tolerance) return false;
  if (horizontal <= kNoDirectionLength) return true;
  return std::abs(wrapAngle(std::atan2(d.y(), d.x()) - parent.heading)) <= region.max_turn + tolerance;
}

// Result of checking a path edge by edge.
struct PathCheck {
  bool ok = true;
  int edge = -1;       // index i of the first bad edge path[i] -> path[i+1], -1 when ok
  std::string reason;  // what was wrong, for messages and tests
};

// Checks every edge of `path` against R+ (each edge's turn measured from the previous edge's direction,
// from path.front().heading for the first), that every state's stored heading equals the direction of
// the edge that reached it, and, when `world` is given, that every edge is collision free.
inline PathCheck checkUnicyclePath(const std::vector<State>& path, const ForwardRegion& region,
                                   const CollisionWorld* world = nullptr, double tolerance = 1e-6) {
  PathCheck check;
  auto fail = [&](int edge, std::string reason) {
    check.ok = false;
    check.edge = edge;
    check.reason = std::move(reason);
    return check;
  };
  if (path.empty()) return fail(-1, "empty path");
  if (world && !world->isFree(path.front().position)) return fail(0, "start state in collision");
  double heading = path.front().heading;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const int edge = static_cast<int>(i);
    const Vec3& from = path[i].position;
    const Vec3& to = path[i + 1].position;
    const Vec3 d = to - from;
    const double horizontal = std::hypot(d.x(), d.y());
    if (horizontal > region.reach + tolerance) {
      return fail(edge, "edge " + std::to_string(i) + " is " + std::to_string(horizontal) +
                            " m long, reach is " + std::to_string(region.reach) + " m");
    }
    if (region.dimensions == 3 && std::abs(d.z()) > region.max_climb + tolerance) {
      return fail(edge, "edge " + std::to_string(i) + " climbs " + std::to_string(d.z()) + " m, limit is " +
                            std::to_string(region.max_climb) + " m");
    }
    const double next_heading = edgeHeading(from, to, heading);
    const double turn = std::abs(wrapAngle(next_heading - heading));
    if (turn > region.max_turn + tolerance) {
      return fail(edge, "edge " + std::to_string(i) + " turns " + std::to_string(turn) + " rad, limit is " +
                            std::to_string(region.max_turn) + " rad");
    }
    if (std::abs(wrapAngle(path[i + 1].heading - next_heading)) > tolerance) {
      return fail(edge, "state " + std::to_string(i + 1) + " heading " + std::to_string(path[i + 1].heading) +
                            " differs from its edge direction " + std::to_string(next_heading));
    }
    if (world && !world->isSegmentFree(from, to)) {
      return fail(edge, "edge " + std::to_string(i) + " is in collision");
    }
    heading = next_heading;
  }
  return check;
}

}  // namespace ddsnav::planner
