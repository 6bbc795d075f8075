#include "ddsnav/tracker/smoother.hpp"

#include "ddsnav/tracker/vehicle.hpp"

#include "ddsnav/planner/coarse_route.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

namespace ddsnav::tracker {

namespace {

using planner::CollisionWorld;

std::string fmt(const Vec3& p, int dims) {
  std::ostringstream s;
  s.precision(4);
  s << "(" << p.x() << ", " << p.y();
  if (dims == 3) s << ", " << p.z();
  s << ")";
  return s.str();
}

[[noreturn]] void fail(const std::string& what) { throw SmoothingError("smoother: " + what); }

// The path length from each point to the last, to compare ways back to a path by their whole length.
std::vector<double> lengthToEnd(const std::vector<Vec3>& points) {
  std::vector<double> remaining(points.size(), 0.0);
  for (std::size_t i = points.size(); i-- > 1;) remaining[i - 1] = remaining[i] + (points[i] - points[i - 1]).norm();
  return remaining;
}

// ---- input checks ---------------------------------------------------------------------------------

std::vector<Vec3> cleanPath(const std::vector<planner::State>& path, int dims) {
  if (path.empty()) fail("path is empty; expected at least 2 states");
  if (path.size() == 1) fail("path has a single state; expected at least 2 states");
  std::vector<Vec3> points;
  points.reserve(path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    Vec3 p = path[i].position;
    if (!p.allFinite() || !std::isfinite(path[i].heading))
      fail("path state " + std::to_string(i) + " has a non-finite position or heading");
    if (dims == 2) p.z() = 0.0;
    // Consecutive duplicates carry no direction; drop them.
    if (!points.empty() && (p - points.back()).norm() < 1e-9) continue;
    points.push_back(p);
  }
  if (points.size() < 2)
    fail("all " + std::to_string(path.size()) + " path states are at the same position; expected at least 2 distinct");
  return points;
}

void checkLimits(const planner::VehicleLimits& l, int dims, const SmootherConfig& c) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(l.v_max)) fail("vehicle v_max must be a positive number, got " + std::to_string(l.v_max));
  if (!positive(l.omega_max)) fail("vehicle omega_max must be a positive number, got " + std::to_string(l.omega_max));
  if (dims == 3 && !positive(l.vz_max)) fail("vehicle vz_max must be a positive number in 3-D, got " + std::to_string(l.vz_max));
  if (!positive(c.sample_dt)) fail("sample_dt must be a positive number");
  if (!positive(c.limit_fraction) || c.limit_fraction > 1.0) fail("limit_fraction must be in (0, 1]");
  if (!positive(c.max_accel)) fail("max_accel must be a positive number");
  if (!(c.max_lateral_accel > 0.0)) fail("max_lateral_accel must be > 0");
  if (!(c.max_vertical_accel > 0.0)) fail("max_vertical_accel must be > 0 (infinity: no limit)");
  if (!std::isfinite(c.corner_radius)) fail("corner_radius must be finite");
  if (!(c.shortcut_clearance >= 0.0)) fail("shortcut_clearance must be >= 0");
  if (!(c.clearance_target >= 0.0) || !std::isfinite(c.clearance_target)) fail("clearance_target must be a number >= 0");
  if (c.initial_heading && !std::isfinite(*c.initial_heading)) fail("initial_heading must be finite");
  if (!(c.end_tolerance >= 0.0) || !std::isfinite(c.end_tolerance)) fail("end_tolerance must be a number >= 0");
  if (!(c.lead_in_decel >= 0.0) || !std::isfinite(c.lead_in_decel)) fail("lead_in_decel must be a number >= 0");
  if (!(c.short_braking_m >= 0.0) || !std::isfinite(c.short_braking_m)) fail("short_braking_m must be a number >= 0");
  if (!(c.repair_distance >= 0.0) || !std::isfinite(c.repair_distance)) fail("repair_distance must be a number >= 0");
}

// The most time repairPath spends on lattice detours in one smoothing.
constexpr double kDetourSearchS = 0.02;

// How far (m) the vehicle may fall behind in z where the trajectory's vertical speed jumps (a kink in its climb):
// the reference's vz changes at once, the vehicle's at the vertical acceleration, so it lags by dvz^2 / (2 a).
constexpr double kVerticalKinkM = 0.05;
double verticalKinkDeviation(double dvz, double a_vz) { return dvz * dvz / (2.0 * a_vz); }
// The arc length (m) over which the slope on each side of a curve point is measured for its vertical curvature: long
// enough that a kink reads as the change it makes over it, short against a corner rounded at the turn radius.
constexpr double kClimbWindowM = 0.25;

// The way round an edge from `a` to `b` (both free) that the world blocks further than a bridge near its middle mends:
// the lattice route between them (planner::findCoarseRoute, within `left_s` of wall time, which it reduces), shortcut
// (planner::pathAlongRoute): the points between a and b, or none. Such edges were planned on an older map than the
// tracker's: a wall the planner had not seen yet cuts them (a jittered S-tunnel at speed 4, 2026-12-06: 8 of a
// mission's 10 refused plans), and a refusal costs a new request.
std::vector<Vec3> latticeDetour(const CollisionWorld& world, const Vec3& a, const Vec3& b, double& left_s) {
  if (!(left_s > 1e-3)) return {};
  planner::CoarseRouteOptions options;
  options.time_limit_s = left_s;
  planner::CoarseRoute route;
  std::vector<planner::State> path;
  try {
    route = planner::findCoarseRoute(world, a, b, world.robotRadius(), options);
    left_s -= route.time_s;
    if (route.outcome != planner::CoarseRoute::Outcome::found) return {};
    path = planner::pathAlongRoute(world, route, planner::State{a, 0.0}, b, 0.0);
  } catch (const std::invalid_argument&) {
    return {};  // a world the lattice cannot span (its bounds): no detour, the edge is refused as before
  }
  if (path.size() < 2 || (path.back().position - b).norm() > 1e-9) return {};
  std::vector<Vec3> between;
  for (std::size_t i = 1; i + 1 < path.size(); ++i) between.push_back(path[i].position);
  return between;
}

// SmootherConfig::repair_distance: the states (the start too) that the world finds in collision are moved to the
// nearest free position within max_move (with a quarter of it of clearance where that is as near), or, deeper in, left
// out (but the last), then an edge blocked
// between two free points gets the nearest free position to the middle of its stretch in collision in between, when
// both halves are free, else the lattice route between them (latticeDetour). Returns
// how many points were moved or added; what it cannot mend is left for checkPathFree to refuse.
std::size_t repairPath(std::vector<Vec3>& points, const CollisionWorld& world, double max_move) {
  if (!(max_move > 0.0)) return 0;
  double lattice_left_s = kDetourSearchS;
  const double step = max_move / 6.0;
  const auto nearestFree = [&](const Vec3& p) { return planner::nearestFreePosition(world, p, max_move, step, 0.25 * max_move); };
  std::size_t repaired = 0;
  // The start too, when it lies just inside (the planner moves a start it finds in collision by the same rule,
  // nodes::plannerStartOutOfCollision, on its own world): a 2-D mission's vehicle stood at rest 0.08 m from a wall,
  // the planner moved its start off the wall by 0.08 m, and the tracker's world — built later, seen from that start —
  // still found it in collision, ten plans in a row ("no drivable trajectory after 10 attempts", CI, 2026-12-07).
  if (!world.isFree(points.front()))
    if (const auto moved = nearestFree(points.front())) {
      points.front() = *moved;
      ++repaired;
    }
  std::vector<Vec3> kept{points.front()};
  for (std::size_t i = 1; i < points.size(); ++i) {
    if (world.isFree(points[i])) {
      kept.push_back(points[i]);
    } else if (const auto moved = nearestFree(points[i])) {
      kept.push_back(*moved);
      ++repaired;
    } else if (i + 1 == points.size()) {
      kept.push_back(points[i]);  // the end stays: refused below
    } else {
      ++repaired;  // deeper in than max_move (a wall the planner had not seen): the edges round it are mended below
    }
  }
  points = std::move(kept);
  std::vector<Vec3> bridged{points.front()};
  for (std::size_t i = 1; i < points.size(); ++i) {
    const Vec3 a = bridged.back();
    const Vec3& b = points[i];
    if (world.isFree(a) && world.isFree(b) && !world.isSegmentFree(a, b)) {
      // Around the middle of the stretch in collision: an edge leaving a passage cuts the corner at its end, near one of
      // its ends, where the nearest free position to the edge's own middle is no way round.
      const double length = (b - a).norm();
      const int steps = std::max(1, static_cast<int>(std::ceil(length / world.checkResolution())));
      int first = -1, last = -1;
      for (int k = 0; k <= steps; ++k) {
        if (world.isFree(a + (b - a) * (static_cast<double>(k) / steps))) continue;
        if (first < 0) first = k;
        last = k;
      }
      const auto around = nearestFree(a + (b - a) * (0.5 * (first + last) / steps));
      if (around && world.isSegmentFree(a, *around) && world.isSegmentFree(*around, b)) {
        bridged.push_back(*around);
        ++repaired;
      } else if (const auto detour = latticeDetour(world, a, b, lattice_left_s); !detour.empty()) {
        bridged.insert(bridged.end(), detour.begin(), detour.end());
        repaired += detour.size();
      }
    }
    bridged.push_back(b);
  }
  points = std::move(bridged);
  return repaired;
}

void checkPathFree(const std::vector<Vec3>& points, const CollisionWorld& world) {
  const int dims = world.dimensions();
  if (!world.isFree(points.front()))
    fail("path start " + fmt(points.front(), dims) + " is in collision or out of bounds (robot radius " +
         std::to_string(world.robotRadius()) + ")");
  for (std::size_t i = 1; i < points.size(); ++i) {
    if (!world.isFree(points[i]))
      fail("path state " + std::to_string(i) + " " + fmt(points[i], dims) + " is in collision or out of bounds");
    if (!world.isSegmentFree(points[i - 1], points[i]))
      fail("path edge " + std::to_string(i - 1) + " -> " + std::to_string(i) + " " + fmt(points[i - 1], dims) +
           " -> " + fmt(points[i], dims) + " is not collision free");
  }
}

// ---- shortcutting ----------------------------------------------------------------------------------


// Moves the polyline away from obstacles where it runs closer than `wanted`, so that tracking errors do not
// become collisions: edges that come closer are split into pieces of at most `spacing`, and each interior
// point climbs the clearance field (away from its nearest obstacle) while that increases its clearance and
// keeps both of its edges free. Points stop at `wanted`, or in the middle of passages narrower than that.
std::vector<Vec3> keepAwayFromObstacles(const std::vector<Vec3>& pts, const CollisionWorld& world, double wanted,
                                        double spacing, double end_tolerance) {
  if (wanted <= 0.0 || pts.size() < 2) return pts;
  std::vector<Vec3> out{pts.front()};
  for (std::size_t i = 1; i < pts.size(); ++i) {
    const Vec3 a = pts[i - 1], b = pts[i];
    if (!planner::segmentClearanceAtLeast(world, a, b, wanted)) {
      const int pieces = std::max(2, static_cast<int>(std::ceil((b - a).norm() / spacing)));
      for (int k = 1; k < pieces; ++k) out.push_back(a + (b - a) * (static_cast<double>(k) / pieces));
    }
    out.push_back(b);
  }
  const bool flat = world.dimensions() == 2;
  std::vector<double> clear(out.size());
  for (std::size_t i = 0; i < out.size(); ++i) clear[i] = world.clearance(out[i]);
  // A point's step depends only on it and its two neighbours: one that found no step that helps finds none again until
  // a neighbour moves, so it is not tried again until then (the result is the same; in a bug trap's 1.6 m neck no
  // point reaches the target and each was tried in all 25 rounds, two thirds of a smoothing).
  std::vector<char> settled(out.size(), 0);
  for (int round = 0; round < 25; ++round) {
    bool moved = false;
    const Vec3 end = pts.back();
    const std::size_t last = end_tolerance > 0.0 ? out.size() - 1 : out.size() - 2;  // the end may move a little
    for (std::size_t i = 1; i <= last; ++i) {
      if (clear[i] >= wanted || settled[i]) continue;
      settled[i] = 1;
      const bool is_end = i + 1 == out.size();
      const auto near = world.obstaclesNear(out[i], world.robotRadius() + wanted);
      if (near.empty()) continue;
      Vec3 away = out[i] - near.front().nearest_point;
      if (flat) away.z() = 0.0;
      if (away.norm() < 1e-9) continue;
      // Halve the step until it helps: a full step can overshoot the middle of a narrow passage.
      for (double step = std::max(0.004, 0.5 * (wanted - clear[i])); step >= 0.002; step *= 0.5) {
        const Vec3 q = out[i] + away.normalized() * step;
        const double cq = world.clearance(q);
        if (cq <= clear[i] + 1e-4 || !world.isFree(q) || !world.isSegmentFree(out[i - 1], q) ||
            (!is_end && !world.isSegmentFree(q, out[i + 1])) || (is_end && (q - end).norm() > end_tolerance))
          continue;
        out[i] = q;
        clear[i] = cq;
        settled[i] = settled[i - 1] = 0;
        if (i + 1 < out.size()) settled[i + 1] = 0;
        moved = true;
        break;
      }
    }
    if (!moved) break;
  }
  return out;
}

// Direction change at the middle point, rad.
double deflection(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = (b - a).normalized(), w = (c - b).normalized();
  return std::atan2(u.cross(w).norm(), u.dot(w));
}

std::vector<Vec3> dropCollinear(const std::vector<Vec3>& points) {
  std::vector<Vec3> out{points.front()};
  for (std::size_t i = 1; i + 1 < points.size(); ++i)
    if (deflection(out.back(), points[i], points[i + 1]) > 1e-6) out.push_back(points[i]);
  out.push_back(points.back());
  return out;
}

// ---- the B-spline through the corners -------------------------------------------------------------
//
// Each interior corner c_k with incoming direction u_in and outgoing direction u_out contributes the
// three control points c_k - d_k u_in, c_k, c_k + d_k u_out. Because consecutive corners' control points
// all lie on the polyline's edges, every span whose four control points are collinear is exactly the
// polyline edge; only the spans next to a corner bend, and they stay within d_k sin(angle) / 6 of the
// polyline. Shrinking d_k therefore pulls the curve onto the (collision-free) polyline locally.

struct Corners {
  std::vector<Vec3> points;   // the polyline, start and goal included
  std::vector<double> size;   // d_k per point (0 for start and goal)
};

// Corner size that makes the curvature at the corner's knot equal to 1/radius: for the pattern above
// the curvature there is 2 sin(a/2) / (d cos^2(a/2)), a the deflection angle.
double cornerSizeFor(double angle, double radius) {
  const double c = std::cos(angle / 2);
  if (c < 1e-6) return std::numeric_limits<double>::infinity();
  return radius * 2.0 * std::sin(angle / 2) / (c * c);
}

Corners makeCorners(const std::vector<Vec3>& points, double radius, const CollisionWorld& world, double clearance_target) {
  Corners c{points, std::vector<double>(points.size(), 0.0)};
  for (std::size_t k = 1; k + 1 < points.size(); ++k) {
    const double in = (points[k] - points[k - 1]).norm(), out = (points[k + 1] - points[k]).norm();
    const double angle = deflection(points[k - 1], points[k], points[k + 1]);
    // Neighbouring corners share an edge: each takes at most 45% of it.
    c.size[k] = std::min({cornerSizeFor(angle, radius), 0.45 * in, 0.45 * out});
    // Where the corner is tight on space, the curve may leave the polyline by at most half the corner's
    // clearance: the deviation is at most d sin(angle) / 6.
    // The room is the least clearance of the polyline where this corner's curve runs (up to 2 d either
    // side); shrinking d shrinks that stretch, so settle it in a few rounds.
    if (clearance_target > 0.0) {
      const Vec3 u_in = (points[k] - points[k - 1]).normalized(), u_out = (points[k + 1] - points[k]).normalized();
      for (int round = 0; round < 3; ++round) {
        double room = world.clearance(points[k]);
        for (double f : {0.25, 0.5, 1.0, 1.5, 2.0}) {
          room = std::min(room, world.clearance(points[k] - f * c.size[k] * u_in));
          room = std::min(room, world.clearance(points[k] + f * c.size[k] * u_out));
        }
        if (room >= clearance_target) break;
        c.size[k] = std::min(c.size[k], 3.0 * std::max(room, 0.0) / std::max(std::sin(angle), 1e-3));
      }
    }
  }
  return c;
}

// Control point index -> corner index, so a collision in a span can be traced to the corners that shape it.
int cornerOfControlPoint(int index, int corner_count) {
  if (index <= 0) return 0;
  const int k = (index + 2) / 3;  // corner k owns control points 3k-2, 3k-1, 3k
  return std::min(k, corner_count - 1);
}

BSpline makeSpline(const Corners& c) {
  std::vector<Vec3> cps{c.points.front()};
  const std::size_t n = c.points.size();
  for (std::size_t k = 1; k + 1 < n; ++k) {
    const Vec3 in = (c.points[k] - c.points[k - 1]).normalized();
    const Vec3 out = (c.points[k + 1] - c.points[k]).normalized();
    cps.push_back(c.points[k] - c.size[k] * in);
    cps.push_back(c.points[k]);
    cps.push_back(c.points[k] + c.size[k] * out);
  }
  cps.push_back(c.points.back());
  if (cps.size() == 2) {  // a single straight edge: four collinear control points
    const Vec3 a = cps[0], b = cps[1];
    cps = {a, a + (b - a) / 3.0, a + 2.0 * (b - a) / 3.0, b};
  }
  return BSpline::clampedUniform(std::move(cps));
}

// ---- dense geometric samples of the curve ----------------------------------------------------------

struct CurvePoint {
  double u = 0.0;
  Vec3 position;
  double heading = 0.0;  // unwrapped
};

std::vector<CurvePoint> sampleCurve(const BSpline& spline, double max_step) {
  std::vector<CurvePoint> pts;
  std::vector<double> raw_heading;
  std::vector<bool> heading_known;
  auto add = [&](double u) {
    Vec3 p, d1, d2;
    spline.evaluate(u, p, d1, d2);
    const double h = std::hypot(d1.x(), d1.y());
    pts.push_back({u, p, 0.0});
    raw_heading.push_back(h > 1e-9 ? std::atan2(d1.y(), d1.x()) : 0.0);
    heading_known.push_back(h > 1e-9);
  };
  const auto& cp = spline.control_points;
  for (int s = 0; s < spline.spanCount(); ++s) {
    // The span's control polygon is at least as long as the span: a safe first guess for the count.
    double poly = 0.0;
    for (int j = 0; j < 3; ++j) poly += (cp[s + j + 1] - cp[s + j]).norm();
    const int m = std::max(1, static_cast<int>(std::ceil(poly / max_step)));
    const double u0 = spline.knots[s + 3], u1 = spline.knots[s + 4];
    for (int i = 0; i < m; ++i) {
      const double u = u0 + (u1 - u0) * i / m;
      if (!pts.empty()) {
        // Parameter speed varies inside a span: bisect until consecutive samples are close enough.
        double ua = pts.back().u;
        Vec3 pa = pts.back().position;
        while ((spline.point(u) - pa).norm() > max_step) {
          double ub = u;
          while ((spline.point(ub) - pa).norm() > max_step && ub - ua > 1e-12) ub = 0.5 * (ua + ub);
          add(ub);
          ua = ub;
          pa = pts.back().position;
        }
      }
      add(u);
    }
  }
  add(spline.parameterMax());

  // Where the tangent vanishes (a corner tightened to a point, or a vertical climb in 3-D) the heading is
  // the direction of travel from there: take it from the neighbouring chord, else hold the previous one.
  const std::size_t n = pts.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (heading_known[i]) continue;
    Vec3 chord = Vec3::Zero();
    for (std::size_t j = i + 1; j < n && std::hypot(chord.x(), chord.y()) < 1e-9; ++j) chord = pts[j].position - pts[i].position;
    if (std::hypot(chord.x(), chord.y()) < 1e-9)
      for (std::size_t j = i; j-- > 0 && std::hypot(chord.x(), chord.y()) < 1e-9;) chord = pts[i].position - pts[j].position;
    if (std::hypot(chord.x(), chord.y()) >= 1e-9) {
      raw_heading[i] = std::atan2(chord.y(), chord.x());
    } else if (i > 0) {
      raw_heading[i] = raw_heading[i - 1];  // purely vertical: keep facing the same way
    }
  }
  pts[0].heading = raw_heading[0];
  for (std::size_t i = 1; i < n; ++i) pts[i].heading = pts[i - 1].heading + wrapAngle(raw_heading[i] - raw_heading[i - 1]);
  return pts;
}

// Spans (first control point index) whose samples are not free, with the first colliding point of each.
std::map<int, Vec3> collidingSpans(const BSpline& spline, const std::vector<CurvePoint>& pts, const CollisionWorld& world) {
  std::map<int, Vec3> spans;
  for (const auto& p : pts)
    if (!world.isFree(p.position)) spans.emplace(spline.firstControlPoint(p.u), p.position);
  return spans;
}

// Every state on a-b is free, checked at least as finely as the curve samples are (the world's own edge
// check may be coarser: that is how a graze got through in the first place).
bool finelyFree(const CollisionWorld& world, const Vec3& a, const Vec3& b) {
  if (!world.isSegmentFree(a, b)) return false;
  const double step = 0.5 * std::min(0.05, world.checkResolution());
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  for (int i = 0; i <= n; ++i)
    if (!world.isFree(a + (b - a) * (static_cast<double>(i) / n))) return false;
  return true;
}

// The point of the polyline nearest to `p`: on edge `edge`, at `f` (0..1) along it.
struct PolylineFoot {
  std::size_t edge = 0;
  double f = 0.0;
  Vec3 foot;
};
PolylineFoot nearestOnPolyline(const std::vector<Vec3>& points, const Vec3& p) {
  PolylineFoot out{0, 0.0, p};
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const Vec3 a = points[i], ab = points[i + 1] - a;
    const double f = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-18), 0.0, 1.0);
    const double d = (p - (a + f * ab)).norm();
    if (d < best) best = d, out = {i, f, a + f * ab};
  }
  return out;
}

// Whether the polyline is blocked at its point nearest to `p` or within 0.25 m along it from there, checked finely.
bool polylineBlockedNear(const std::vector<Vec3>& points, const Vec3& p, const CollisionWorld& world) {
  if (points.size() < 2) return false;
  const PolylineFoot near = nearestOnPolyline(points, p);
  const Vec3 a = points[near.edge], ab = points[near.edge + 1] - a;
  const double reach = 0.25 / std::max(ab.norm(), 1e-12);
  return !world.isFree(near.foot) ||
         !finelyFree(world, a + std::max(0.0, near.f - reach) * ab, a + std::min(1.0, near.f + reach) * ab);
}

// The polyline itself touches an obstacle near `hit` (its edges were checked at the world's resolution; a
// finer look can find a graze between two checked states). Insert a new corner next to it, pushed off the edge as
// little as makes both new edges free. Returns false when no push up to 0.3 m works.
bool pushPolylineAway(Corners& c, const Vec3& hit, const CollisionWorld& world, double radius) {
  const int dims = world.dimensions();
  const PolylineFoot nearest = nearestOnPolyline(c.points, hit);
  const std::size_t edge = nearest.edge;
  Vec3 foot = nearest.foot;
  const Vec3 a = c.points[edge], b = c.points[edge + 1];
  if ((foot - a).norm() < 1e-6 || (foot - b).norm() < 1e-6) foot = 0.5 * (a + b) + 0.5 * (foot - 0.5 * (a + b)) * 0.98;
  // Directions to push in: away from the nearest obstacle, then across the edge both ways (and in 3-D up and down
  // across it). The nearest obstacle alone is not enough: where the map widens terrain by its surface margin, the
  // blocked space is a box of columns, and a shortcut that grazes one of its corners is kept off it by a step
  // sideways, not by one away from the voxel it was widened from (r3d_128 of make_random_scenarios.py: an 18 m edge
  // through the corner of such a box, the plan refused).
  const Vec3 t = (b - a).normalized();
  Vec3 side(-t.y(), t.x(), 0.0);
  if (side.norm() < 1e-6) side = Vec3::UnitX();  // a vertical edge
  side.normalize();
  if (world.clearance(foot - 0.01 * side) > world.clearance(foot + 0.01 * side)) side = -side;
  std::vector<Vec3> directions;
  const auto near = world.obstaclesNear(foot, world.robotRadius() + 1.0);
  if (!near.empty()) {
    Vec3 away = foot - near.front().nearest_point;
    if (dims == 2) away.z() = 0.0;
    if (away.norm() > 1e-9) directions.push_back(away.normalized());
  }
  directions.push_back(side);
  directions.push_back(-side);
  if (dims == 3) {
    const Vec3 up = t.cross(side).normalized();
    directions.push_back(up.z() >= 0 ? up : Vec3(-up));
    directions.push_back(up.z() >= 0 ? Vec3(-up) : up);
  }
  // The smallest push first, whichever way.
  std::optional<Vec3> pushed;
  for (double push = 0.005; push <= 0.3 && !pushed; push *= 1.6)
    for (const Vec3& direction : directions) {
      const Vec3 q = foot + push * direction;
      if (world.isFree(q) && finelyFree(world, a, q) && finelyFree(world, q, b)) {
        pushed = q;
        break;
      }
    }
  if (pushed) {
    const Vec3 q = *pushed;
    c.points.insert(c.points.begin() + static_cast<std::ptrdiff_t>(edge) + 1, q);
    c.size.insert(c.size.begin() + static_cast<std::ptrdiff_t>(edge) + 1, 0.0);
    // The new corner and its neighbours get their normal rounding back (capped by the new, shorter edges).
    for (std::size_t k = edge; k <= edge + 2 && k < c.points.size(); ++k) {
      if (k == 0 || k + 1 >= c.points.size()) continue;
      const double in = (c.points[k] - c.points[k - 1]).norm(), out = (c.points[k + 1] - c.points[k]).norm();
      const double want = cornerSizeFor(deflection(c.points[k - 1], c.points[k], c.points[k + 1]), radius);
      c.size[k] = k == edge + 1 ? std::min({want, 0.45 * in, 0.45 * out}) : std::min({c.size[k], 0.45 * in, 0.45 * out});
    }
    return true;
  }
  return false;
}

// ---- lead-in ------------------------------------------------------------------------------------------

// No lead-in at speed fitted: brake to rest straight along the heading (`braking_length`, the stop at the lead-in's
// deceleration and some slack), turn in place there and join the path at whichever of its first points makes the
// whole way shortest — a path that turns back (inside a bug trap every replan does) is joined near its start.
// It is the stop the tracker would otherwise make after refusing the plan, without the refusals and the planning
// round trip from rest. Nothing (and why in `failure`) when the braking line or every way back to the path is
// blocked.
std::optional<std::vector<Vec3>> brakingLeadIn(const std::vector<Vec3>& points, const std::vector<Vec3>& directions,
                                               double braking_length, const CollisionWorld& world, double min_clearance,
                                               double stop_clearance, std::string& failure) {
  auto describe = [](double l, const char* why) {
    char text[96];
    std::snprintf(text, sizeof text, "braking in %.1f m: %s", l, why);
    return std::string(text);
  };
  const Vec3& start = points.front();
  // The braking line keeps stop_clearance (the smoother's clearance target), or 70 % of the start's own where that is
  // less (a corridor, which a heading a few degrees off its axis approaches): it must not end close to what the vehicle
  // stops for, as an overshoot of the stop goes on along the heading (stunnel_1.0: a stop 0.2 m before the end wall at
  // 0.1 m allowed, the vehicle 0.13 m into it).
  const double start_clearance = world.clearance(start);
  const double need = std::max(std::min(min_clearance, start_clearance), std::min(stop_clearance, 0.7 * start_clearance));
  const std::vector<double> remaining = lengthToEnd(points);
  constexpr std::size_t kJoinCandidates = 10;  // path points tried as the way back: the first ten after the start
  for (const Vec3& direction : directions) {
    const Vec3 ahead = start + braking_length * direction;
    if (!world.isFree(ahead) || !world.isSegmentFree(start, ahead) || !planner::segmentClearanceAtLeast(world, start, ahead, need)) {
      failure = describe(braking_length, "the braking line is blocked");
      continue;
    }
    std::size_t best = 0;
    double best_length = std::numeric_limits<double>::infinity();
    for (std::size_t k = 1; k < std::min(points.size(), 1 + kJoinCandidates); ++k) {
      const double way = (points[k] - ahead).norm() + remaining[k];
      if (way >= best_length) continue;
      if (!world.isSegmentFree(ahead, points[k]) || !planner::segmentClearanceAtLeast(world, ahead, points[k], std::min(need, world.clearance(points[k]))))
        continue;
      best = k, best_length = way;
    }
    if (best == 0) {
      failure = describe(braking_length, "no way back to the path from the stop");
      continue;
    }
    std::vector<Vec3> out{start, ahead};
    out.insert(out.end(), points.begin() + static_cast<std::ptrdiff_t>(best), points.end());
    return out;
  }
  return std::nullopt;
}

// The corner a lead-in makes between directions `a` and `b`, rad. The turn radius bounds horizontal turns (omega); a
// change of climb is the vertical rate's business, left to the time parametrisation. So in 3-D the corner is measured
// in the horizontal plane: the 3-D angle counted a hillside's 20 degrees of climb as a turn, and every short lead-in
// of a climbing UAV was "too tight".
double leadInCorner(const Vec3& a, const Vec3& b, int dims) {
  Vec3 u = a, w = b;
  if (dims == 3 && std::hypot(u.x(), u.y()) > 1e-6 && std::hypot(w.x(), w.y()) > 1e-6) u.z() = 0.0, w.z() = 0.0;
  return std::acos(std::clamp(u.normalized().dot(w.normalized()), -1.0, 1.0));
}

// The change of climb angle between directions `a` and `b`, rad (3-D; 0 where either is vertical).
double climbChange(const Vec3& a, const Vec3& b) {
  const double ha = std::hypot(a.x(), a.y()), hb = std::hypot(b.x(), b.y());
  if (ha < 1e-9 || hb < 1e-9) return 0.0;
  return std::abs(std::atan2(b.z(), hb) - std::atan2(a.z(), ha));
}

// A lead-in along `along` (SmootherConfig::lead_in_path; its first point is the start): half a piece along `heading`
// (a unit vector), then the first `l` metres of `along`, for l from `length` down to 0.5 m (x 0.7), kept a metre or a sixth of
// l apart, whose edges are free with the clearance a straight lead-in needs or their ends' where less, joined to the path
// ahead of its end (one of its first points, else a point on one of its first edges) by an edge like a straight
// lead-in's (free, clear, its corners roundable at `turn_radius`). The corners along it are the flown trajectory's own. The points
// and l; nothing when none fits (`failure` gets the reason of the longest).
std::optional<std::pair<std::vector<Vec3>, double>> leadInAlong(const std::vector<Vec3>& points, const std::vector<Vec3>& along, const Vec3& heading,
                                             double length, double turn_radius, const CollisionWorld& world, double min_clearance,
                                             std::string& failure) {
  // It must start where the path does (a planner that moved the start off an obstacle planned from elsewhere).
  if (along.size() < 2 || points.size() < 2 || (along.front() - points.front()).norm() > 0.05) return std::nullopt;
  std::vector<double> arc(along.size(), 0.0);
  for (std::size_t i = 1; i < along.size(); ++i) arc[i] = arc[i - 1] + (along[i] - along[i - 1]).norm();
  const Vec3& start = points.front();
  const double need = std::min(min_clearance, world.clearance(start));
  std::string longest;
  auto failed = [&](double l, const char* why) {
    if (!longest.empty()) return;
    char text[128];
    std::snprintf(text, sizeof text, "along the flown trajectory, %.1f m: %s", l, why);
    longest = text;
  };
  // The point at arc length s along `along`.
  auto at = [&](double s) {
    const auto upper = std::upper_bound(arc.begin(), arc.end(), s);
    const std::size_t i = std::clamp<std::size_t>(static_cast<std::size_t>(upper - arc.begin()), 1, arc.size() - 1);
    const double span = arc[i] - arc[i - 1];
    return span > 1e-12 ? Vec3(along[i - 1] + (along[i] - along[i - 1]) * ((s - arc[i - 1]) / span)) : along[i];
  };
  for (double l = std::min(length, arc.back()); l >= std::min(0.5, length) - 1e-9; l *= 0.7) {
    const double spacing = std::max(1.0, l / 6.0);
    const int pieces = std::max(1, static_cast<int>(std::ceil(l / spacing - 1e-9)));
    // The first step is along the heading itself, half a piece (a chord of the flown curve is a degree or two off its
    // tangent, and a start off the heading turns in place, at rest); long enough for the corner after it to be rounded.
    const double tangent_step = 0.5 * std::min(spacing, l);
    std::vector<Vec3> lead{start};
    bool clear = true;
    for (int k = 0; k <= pieces && clear; ++k) {
      const Vec3 next = k == 0 ? Vec3(start + tangent_step * heading) : at(l * k / pieces);
      // As close as its ends are, at most: the flown trajectory may pass nearer to a wall than the start is.
      clear = world.isFree(next) && world.isSegmentFree(lead.back(), next) &&
              planner::segmentClearanceAtLeast(world, lead.back(), next, std::min({need, world.clearance(lead.back()), world.clearance(next)}));
      lead.push_back(next);
    }
    if (!clear) {
      failed(l, "blocked or too close to an obstacle");
      continue;
    }
    const Vec3 end = lead.back();
    const Vec3 direction = (end - lead[lead.size() - 2]).normalized();
    // Back to one of the path's first points ahead of the lead-in's end, else to a point on one of its first edges, a
    // metre apart (in a passage the path's first edge may pass a corner closely, and an edge from beside it to the
    // vertex beyond clips that corner).
    struct Join {
      Vec3 at;
      std::size_t tail;  // the path goes on from points[tail]
    };
    std::vector<Join> joins;
    constexpr std::size_t kJoinVertices = 10;
    for (std::size_t next = 1; next < std::min(points.size(), 1 + kJoinVertices); ++next) joins.push_back({points[next], next});
    double edge_arc = 0.0;
    for (std::size_t next = 1; next < points.size() && edge_arc < 3.0 * length; ++next) {
      const Vec3 from = points[next - 1], to = points[next];
      const double edge = (to - from).norm();
      for (double t = 1.0; t < edge - 0.5; t += 1.0) joins.push_back({Vec3(from + (to - from) * (t / edge)), next});
      edge_arc += edge;
    }
    const char* why = "no way back to the path";
    for (const Join& join : joins) {
      const Vec3 onward = join.at - end;
      if (onward.norm() < 1e-6 || onward.dot(direction) <= 0.0) continue;  // behind the lead-in's end
      const auto corner = [&](const Vec3& a, const Vec3& b) { return leadInCorner(a, b, world.dimensions()); };
      const double first_corner = corner(direction, onward);
      // A join on an edge makes a second corner there, onto the edge.
      const bool on_edge = (join.at - points[join.tail]).norm() > 1e-9;
      const double second_corner = on_edge ? corner(onward, points[join.tail] - join.at) : 0.0;
      const double first_tangent = turn_radius * std::tan(0.5 * first_corner), second_tangent = turn_radius * std::tan(0.5 * second_corner);
      if (first_corner > 0.5 * std::numbers::pi || second_corner > 0.5 * std::numbers::pi || onward.norm() < first_tangent + second_tangent - 1e-9 ||
          (on_edge && (points[join.tail] - join.at).norm() < second_tangent - 1e-9)) {
        why = "the corner back to the path is too tight";
        continue;
      }
      if (!world.isSegmentFree(end, join.at) ||
          !planner::segmentClearanceAtLeast(world, end, join.at, std::min(need, world.clearance(join.at)))) {
        why = "the edge back to the path is blocked";
        continue;
      }
      if (on_edge) lead.push_back(join.at);
      lead.insert(lead.end(), points.begin() + static_cast<std::ptrdiff_t>(join.tail), points.end());
      return std::pair{std::move(lead), l};
    }
    failed(l, why);
  }
  if (!longest.empty()) failure += "; " + longest;
  return std::nullopt;
}

// A start moving at `heading` (and climbing at `climb` = vz / horizontal speed, 3-D): puts a point `length` ahead
// along it after the start, the longest of a few candidates (x 0.7 down to 0.5 m) whose two new edges are
// collision free with `min_clearance` and whose corner at the new point is at most a right angle and can be rounded
// at `turn_radius` (both edges at least radius x tan(corner / 2) long: a tighter corner is a near stop, and the
// tracker then deviates). In 3-D the change of climb at the new point must also be roundable at `vertical_radius`
// (the radius at which the vertical acceleration turns the climb at the start's speed). At each length the climbing
// direction is tried first, then the level one when `level_allowed` (a level start from a climb is a kink in the
// vertical speed at the start, which the vehicle meets late: from a descent at 1.2 m/s it sank 0.69 m below a level
// lead-in, descend_3d). When none is, one along `lead_in_path` (leadInAlong; `along_flown` set to its length), else,
// when `braking_length` > 0, a braking lead-in of that length (`braking` set). Returns the points unchanged when none
// fits.
std::vector<Vec3> leadIn(const std::vector<Vec3>& points, double heading, double climb, bool level_allowed, double length,
                         double turn_radius, double vertical_radius, double braking_length, double stop_clearance,
                         const CollisionWorld& world, double min_clearance, const std::vector<Vec3>& lead_in_path,
                         std::string& failure, bool& braking, double& along_flown) {
  braking = false;
  along_flown = 0.0;
  if (points.size() < 2 || !(length > 0)) return points;
  std::string longest_failure, shortest_failure;
  auto failed = [&](double l, const char* why) {
    char text[96];
    std::snprintf(text, sizeof text, "%.1f m: %s", l, why);
    if (longest_failure.empty()) longest_failure = text;
    shortest_failure = text;
  };
  std::vector<Vec3> directions;
  const bool climbing = std::isfinite(climb) && std::abs(climb) > 1e-3;
  if (climbing) directions.push_back(Vec3(std::cos(heading), std::sin(heading), climb).normalized());
  if (!climbing || level_allowed) directions.push_back(Vec3(std::cos(heading), std::sin(heading), 0.0));
  const Vec3& start = points.front();
  const auto cornerAngle = [&](const Vec3& a, const Vec3& b) { return leadInCorner(a, b, world.dimensions()); };
  // Steps of 0.7: between "blocked" (too long) and "too tight" (too short) the halving often had no length left.
  for (double l = length; l >= std::min(0.5, length) - 1e-9; l *= 0.7) {
    for (const Vec3& direction : directions) {
      const Vec3 ahead = start + l * direction;
      // The first point after the start that lies beyond the lead-in (the ones it passes are dropped).
      std::size_t first = 1;
      while (first + 1 < points.size() && (points[first] - start).dot(direction) <= l) ++first;
      // Back to that point, or to one of the next two (a gentler corner, the points between dropped: a path that
      // curves right after its start — around a hill — left no corner a fast vehicle could round).
      for (std::size_t next = first; next < std::min(points.size(), first + 3); ++next) {
        const Vec3 onward = points[next] - ahead;
        if (onward.norm() < 1e-6) continue;
        // The corner at the new point must be roundable at the turn radius: a tighter one is a near stop.
        const double corner = cornerAngle(direction, onward);
        const double tangent = turn_radius * std::tan(0.5 * corner);
        if (corner > 0.5 * std::numbers::pi) { failed(l, "the path turns back more than a right angle"); continue; }
        if (l < tangent - 1e-9 || onward.norm() < tangent - 1e-9) { failed(l, "the corner is too tight for the turn radius"); continue; }
        const double vertical_tangent = vertical_radius * std::tan(0.5 * climbChange(direction, onward));
        if (l < vertical_tangent - 1e-9 || onward.norm() < vertical_tangent - 1e-9) {
          failed(l, "the climb changes too sharply for the vertical acceleration");
          continue;
        }
        if (!world.isFree(ahead) || !world.isSegmentFree(start, ahead)) { failed(l, "the lead-in is blocked"); break; }
        if (!world.isSegmentFree(ahead, points[next])) { failed(l, "the edge back to the path is blocked"); continue; }
        const double need = std::min(min_clearance, world.clearance(start));
        if (!planner::segmentClearanceAtLeast(world, start, ahead, need)) { failed(l, "too close to an obstacle"); break; }
        if (!planner::segmentClearanceAtLeast(world, ahead, points[next], std::min(need, world.clearance(points[next])))) {
          failed(l, "too close to an obstacle");
          continue;
        }
        std::vector<Vec3> out{start, ahead};
        out.insert(out.end(), points.begin() + static_cast<std::ptrdiff_t>(next), points.end());
        return out;
      }
    }
  }
  failure = longest_failure.empty() ? "no candidate" : longest_failure + (shortest_failure != longest_failure ? "; " + shortest_failure : "");
  if (auto along = leadInAlong(points, lead_in_path, directions.front(), length, turn_radius, world, min_clearance, failure)) {
    failure.clear();
    along_flown = along->second;
    return std::move(along->first);
  }
  if (braking_length > 0) {
    std::string braking_failure;
    if (auto out = brakingLeadIn(points, directions, braking_length, world, min_clearance, stop_clearance, braking_failure)) {
      braking = true;
      return std::move(*out);
    }
    failure += "; " + braking_failure;
  }
  return points;
}

// ---- time parametrisation ------------------------------------------------------------------------

struct Profile {
  std::vector<double> time;   // at each curve point
  std::vector<double> speed;  // path speed ds/dt at each curve point
  std::vector<double> arc;    // arc length at each curve point
};

// `braking_arc`: the first metres of a braking lead-in, where the profile may brake at cfg.lead_in_decel.
Profile timeParametrise(const std::vector<CurvePoint>& pts, const planner::VehicleLimits& limits, int dims,
                        const SmootherConfig& cfg, double braking_arc = 0.0) {
  const std::size_t n = pts.size();
  const double v_eff = cfg.limit_fraction * limits.v_max;
  const double w_eff = cfg.limit_fraction * limits.omega_max;
  const double vz_eff = dims == 3 ? cfg.limit_fraction * limits.vz_max : std::numeric_limits<double>::infinity();
  const double inf = std::numeric_limits<double>::infinity();

  std::vector<double> ds(n - 1), dxy(n - 1), dz(n - 1), dth(n - 1);
  std::vector<double> cap(n, inf);
  std::vector<double> interval_cap(n - 1, inf);  // each interval's own speed limit
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const Vec3 d = pts[i + 1].position - pts[i].position;
    ds[i] = d.norm();
    dxy[i] = std::hypot(d.x(), d.y());
    dz[i] = d.z();
    dth[i] = pts[i + 1].heading - pts[i].heading;
    // Largest path speed on this interval that keeps v, omega, vz and the lateral acceleration in limits.
    double limit = inf;
    if (ds[i] <= 0.0) {
      limit = 0.0;  // turning in place
    } else {
      if (dxy[i] > 0) limit = std::min(limit, v_eff * ds[i] / dxy[i]);
      if (std::abs(dz[i]) > 0) limit = std::min(limit, vz_eff * ds[i] / std::abs(dz[i]));
      if (std::abs(dth[i]) > 0) {
        limit = std::min(limit, w_eff * ds[i] / std::abs(dth[i]));
        if (std::isfinite(cfg.max_lateral_accel) && dxy[i] > 0) {
          const double kappa = std::abs(dth[i]) / dxy[i];
          limit = std::min(limit, std::sqrt(cfg.max_lateral_accel / kappa) * ds[i] / dxy[i]);
        }
      }
    }
    interval_cap[i] = limit;
    cap[i] = std::min(cap[i], limit);
    cap[i + 1] = std::min(cap[i + 1], limit);
  }
  // 3-D: vz = speed x slope changes at speed^2 x the slope's change per metre (plus slope x the path's acceleration),
  // which the vertical acceleration bounds. The corners are rounded at the turn radius, but a corner tightened for
  // room, or between short edges, changes the climb within centimetres.
  const double a_vz = cfg.limit_fraction * cfg.max_vertical_accel;
  Profile prof;
  prof.arc.assign(n, 0.0);
  for (std::size_t i = 0; i + 1 < n; ++i) prof.arc[i + 1] = prof.arc[i] + ds[i];
  const std::vector<double>& arc_at = prof.arc;
  if (dims == 3 && std::isfinite(a_vz) && n > 2) {
    for (std::size_t i = 1, before = 0, after = 1; i + 1 < n; ++i) {
      while (before + 1 < i && arc_at[i] - arc_at[before + 1] >= kClimbWindowM) ++before;
      after = std::max(after, i + 1);
      while (after + 1 < n && arc_at[after] - arc_at[i] < kClimbWindowM) ++after;
      const double back = arc_at[i] - arc_at[before], ahead = arc_at[after] - arc_at[i];
      if (back <= 0.0 || ahead <= 0.0) continue;
      const double slope_in = (pts[i].position.z() - pts[before].position.z()) / back;
      const double slope_out = (pts[after].position.z() - pts[i].position.z()) / ahead;
      const double change_per_m = std::abs(slope_out - slope_in) / (0.5 * (back + ahead));
      if (change_per_m < 1e-9) continue;
      const double budget = std::max(0.5 * a_vz, a_vz - std::max(std::abs(slope_in), std::abs(slope_out)) * cfg.max_accel);
      cap[i] = std::min(cap[i], std::sqrt(budget / change_per_m));
    }
  }
  // Start at the vehicle's speed (0: at rest); in 3-D along the path, its climb included (initial_speed is horizontal).
  const double initial = dims == 3 && cfg.initial_speed > 0 ? std::hypot(cfg.initial_speed, cfg.initial_vz) : cfg.initial_speed;
  cap.front() = std::min(cap.front(), initial);
  // A moving 3-D start whose first slope is not the vehicle's climb jumps in vz: at most as fast as leaves the vehicle
  // kVerticalKinkM behind (the tracker then brakes for the slower start, or refuses it: cannotTakeOver).
  if (dims == 3 && initial > 0 && std::isfinite(a_vz) && ds.front() > 0) {
    std::size_t to = 1;
    while (to + 1 < n && arc_at[to] < kClimbWindowM) ++to;
    const double slope = (pts[to].position.z() - pts.front().position.z()) / arc_at[to];
    const double jump = std::abs(slope - cfg.initial_vz / initial);
    if (jump > 1e-9) cap.front() = std::min(cap.front(), std::sqrt(2.0 * a_vz * kVerticalKinkM) / jump);
  }
  cap.back() = 0.0;                                        // end at rest

  // Forward-backward pass: the fastest profile under the caps with |ds/dt change| <= max_accel.
  auto& v = prof.speed;
  v.assign(n, 0.0);
  v.front() = cap.front();
  for (std::size_t i = 0; i + 1 < n; ++i) v[i + 1] = std::min(cap[i + 1], std::sqrt(v[i] * v[i] + 2 * cfg.max_accel * ds[i]));
  std::vector<double> decel(n - 1, cfg.max_accel);
  for (std::size_t i = 0; i + 1 < n && arc_at[i] < braking_arc; ++i) decel[i] = std::max(cfg.max_accel, cfg.lead_in_decel);
  for (std::size_t i = n - 1; i-- > 0;) v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2 * decel[i] * ds[i]));

  prof.time.assign(n, 0.0);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    double tau = 0.0;
    if (ds[i] > 0) {
      // Speed changing evenly between the ends; but where both ends are far slower than the interval allows, the
      // fastest way along it: speed up at max_accel to a peak (at most the interval's own limit), hold it, slow down.
      // Between two near-stops (by our reading, the ends of a cusp's sub-millimetre intervals, capped near zero by
      // their heading change) the even ramp took 240 s for 12 mm (stunnel_0.5: a 148 m trajectory of 298 s, its samples
      // creeping at ~5e-5 m/s, the vehicle standing at its start until the timeout).
      const double a = cfg.max_accel;
      const double ramp = v[i] + v[i + 1] > 1e-12 ? 2 * ds[i] / (v[i] + v[i + 1]) : 2 * std::sqrt(ds[i] / a);
      const double peak = std::min(interval_cap[i], std::sqrt(0.5 * (2 * a * ds[i] + v[i] * v[i] + v[i + 1] * v[i + 1])));
      double fastest = ramp;
      if (peak > std::max(v[i], v[i + 1]) + 1e-12) {
        const double ramps = (peak * peak - v[i] * v[i] + peak * peak - v[i + 1] * v[i + 1]) / (2 * a);
        fastest = (2 * peak - v[i] - v[i + 1]) / a + std::max(0.0, ds[i] - ramps) / peak;
      }
      tau = ramp > 2 * fastest ? fastest : ramp;
    }
    // The speed caps already imply these; they matter for pure rotations and guard rounding.
    tau = std::max({tau, std::abs(dth[i]) / w_eff, std::abs(dz[i]) / vz_eff});
    prof.time[i + 1] = prof.time[i] + tau;
  }
  return prof;
}

std::vector<TrajectorySample> sampleInTime(const std::vector<CurvePoint>& pts, const Profile& prof, double dt) {
  std::vector<TrajectorySample> out;
  const std::size_t n = pts.size();
  const double total = prof.time.back();
  const auto count = static_cast<std::size_t>(std::floor(total / dt));
  out.reserve(count + 2);
  std::size_t i = 0;
  auto sampleAt = [&](double t) {
    while (i + 2 < n && prof.time[i + 1] <= t) ++i;
    const double tau = prof.time[i + 1] - prof.time[i];
    const double f = tau > 0 ? std::clamp((t - prof.time[i]) / tau, 0.0, 1.0) : 1.0;
    const Vec3 d = pts[i + 1].position - pts[i].position;
    const double ds = d.norm(), dxy = std::hypot(d.x(), d.y());
    const double dth = pts[i + 1].heading - pts[i].heading;
    TrajectorySample s;
    s.time = t;
    s.position = pts[i].position + f * d;
    s.heading = pts[i].heading + f * dth;
    s.arc_length = prof.arc[i] + f * ds;
    // Path speed, scaled down where the interval is slower than its end speeds say (turning in place).
    double path_speed = prof.speed[i] + f * (prof.speed[i + 1] - prof.speed[i]);
    const double sum = prof.speed[i] + prof.speed[i + 1];
    if (tau > 0 && ds > 0 && sum > 0) path_speed *= std::min(1.0, (2 * ds / sum) / tau);
    if (tau > 0 && ds > 0 && sum <= 0) path_speed = ds / tau;
    s.speed = ds > 0 ? path_speed * dxy / ds : 0.0;
    s.vz = ds > 0 ? path_speed * d.z() / ds : 0.0;
    s.yaw_rate = tau > 0 ? dth / tau : 0.0;
    s.curvature = dxy > 1e-12 ? dth / dxy : 0.0;
    out.push_back(s);
  };
  for (std::size_t k = 0; k <= count; ++k) sampleAt(static_cast<double>(k) * dt);
  if (total - out.back().time > 1e-9) sampleAt(total);
  // The last sample is exactly the end of the curve, at rest.
  out.back().position = pts.back().position;
  out.back().heading = pts.back().heading;
  out.back().speed = out.back().vz = out.back().yaw_rate = 0.0;
  out.back().arc_length = prof.arc.back();
  return out;
}

// ---- report -------------------------------------------------------------------------------------------

void fillReport(Trajectory& traj, const CollisionWorld& world, bool clearance) {
  auto& r = traj.report;
  const auto& s = traj.samples;
  r.length = traj.length();
  r.duration = traj.duration();
  for (std::size_t i = 0; i < s.size(); ++i) {
    r.max_curvature = std::max(r.max_curvature, std::abs(s[i].curvature));
    r.max_speed = std::max(r.max_speed, s[i].speed);
    r.max_yaw_rate = std::max(r.max_yaw_rate, std::abs(s[i].yaw_rate));
    r.max_vz = std::max(r.max_vz, std::abs(s[i].vz));
    if (i > 0) {
      const double dt = s[i].time - s[i - 1].time;
      r.max_heading_jump = std::max(r.max_heading_jump, std::abs(s[i].heading - s[i - 1].heading));
      const double v0 = std::hypot(s[i - 1].speed, s[i - 1].vz), v1 = std::hypot(s[i].speed, s[i].vz);
      if (dt > 1e-9) r.max_accel = std::max(r.max_accel, std::abs(v1 - v0) / dt);
    }
  }
  // Slow stretches between the first and the last fast sample.
  auto speed3 = [&](std::size_t i) { return std::hypot(s[i].speed, s[i].vz); };
  double top = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) top = std::max(top, speed3(i));
  const double slow = 0.25 * top;
  std::size_t first = s.size(), last = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (speed3(i) >= slow) first = std::min(first, i), last = i;
  double slowest = std::numeric_limits<double>::infinity();
  for (std::size_t i = first + 1; i < s.size() && i <= last; ++i) {
    if (speed3(i) >= slow) continue;
    r.slow_s += s[i].time - s[i - 1].time;
    if (speed3(i) < slowest) slowest = speed3(i), r.slowest_at = s[i].position;
  }
  if (!clearance) return;
  // The clearance is 1-Lipschitz in the position: a sample nearer to a measured one than that one's clearance
  // minus the least so far cannot be below the least, so it is not measured and the minimum stays exact. In open
  // water this skips most of a long trajectory's samples (auv_coastal: 9 300 queries, 55 % of a smoothing).
  for (std::size_t i = 0; i < s.size();) {
    const double c = world.clearance(s[i].position);
    r.min_clearance = std::min(r.min_clearance, c);
    if (c == std::numeric_limits<double>::infinity()) break;  // nothing anywhere to come close to
    const double slack = c - r.min_clearance;
    std::size_t next = i + 1;
    while (next < s.size() && (s[next].position - s[i].position).norm() < slack) ++next;
    i = next;
  }
}

}  // namespace

std::optional<std::string> findCrawl(const Trajectory& trajectory, const planner::VehicleLimits& limits) {
  constexpr double kCrawlSpeed = 0.01;   // m/s, along the path
  constexpr double kLongestCrawl = 5.0;  // s
  const auto& s = trajectory.samples;
  std::size_t first = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool crawling = std::hypot(s[i].speed, s[i].vz) < kCrawlSpeed && std::abs(s[i].yaw_rate) < 0.05 * limits.omega_max;
    if (!crawling) {
      first = i + 1;
      continue;
    }
    if (s[i].time - s[first].time > kLongestCrawl) {
      char text[160];
      std::snprintf(text, sizeof text, "for over %.0f s from t = %.1f s at (%.2f, %.2f, %.2f): below %.2f m/s, not turning in place",
                    kLongestCrawl, s[first].time, s[first].position.x(), s[first].position.y(), s[first].position.z(), kCrawlSpeed);
      return std::string(text);
    }
  }
  return std::nullopt;
}

std::vector<Vec3> shortcutPolyline(const std::vector<Vec3>& points, const CollisionWorld& world, double min_clearance,
                                   double tolerance) {
  const int n = static_cast<int>(points.size());
  if (n <= 2) return points;
  std::vector<double> point_clearance(n, std::numeric_limits<double>::infinity());
  if (min_clearance > 0)
    for (int i = 0; i < n; ++i) point_clearance[i] = world.clearance(points[i]);
  // A shortcut may come as close to obstacles as its own ends do, but no closer than min_clearance (either
  // less the tolerance).
  auto ok = [&](int i, int j) {
    const double need = std::min({min_clearance, point_clearance[i], point_clearance[j]}) - tolerance;
    return world.isSegmentFree(points[i], points[j]) && planner::segmentClearanceAtLeast(world, points[i], points[j], need);
  };
  std::vector<int> kept{0};  // indices into points
  int i = 0;
  while (i < n - 1) {
    // Exponential then binary search for the farthest point reachable by a straight shortcut. Visibility
    // is not monotone along a path, so this is a heuristic; every accepted shortcut is checked.
    int best = i + 1, fail_at = -1, step = 1;
    while (true) {
      const int probe = std::min(n - 1, i + 1 + step);
      if (probe <= best) break;
      if (ok(i, probe)) {
        best = probe;
        if (probe == n - 1) break;
        step *= 2;
      } else {
        fail_at = probe;
        break;
      }
    }
    if (fail_at > 0) {
      int hi = fail_at;
      while (hi - best > 1) {
        const int mid = (best + hi) / 2;
        if (ok(i, mid)) best = mid; else hi = mid;
      }
    }
    kept.push_back(best);
    i = best;
  }
  // The search above stops at a boundary of a predicate that is not monotone, not always at the farthest point in
  // sight: it left a corner a straight edge from the one before to the one after could do without. Around an
  // obstacle the clearance push bent the path round, such a corner made a jog of two corners 0.8 m apart, each
  // rounded over at most 45 % of that, a turn of curvature 2.5 1/m the vehicle crawled through (r2d_151 of
  // make_random_scenarios.py: its first trajectory 4.4 s below a quarter of top speed, 1.6 s with this). Fewer corners
  // is less turning, and a turn the turn rate limits takes its angle / omega_max however wide it is rounded. Drop each
  // corner whose neighbours see each other, until none does.
  for (bool dropped = true; dropped && kept.size() > 2;) {
    dropped = false;
    for (std::size_t k = 1; k + 1 < kept.size();) {
      if (ok(kept[k - 1], kept[k + 1])) {
        kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(k));
        dropped = true;
      } else {
        ++k;
      }
    }
  }
  std::vector<Vec3> out;
  out.reserve(kept.size());
  for (const int k : kept) out.push_back(points[k]);
  return out;
}

Trajectory smoothPath(const std::vector<planner::State>& path, const CollisionWorld& world,
                      const planner::VehicleLimits& limits, const SmootherConfig& config) {
  const int dims = world.dimensions();
  checkLimits(limits, dims, config);
  std::vector<Vec3> points = cleanPath(path, dims);
  const std::size_t input_waypoints = points.size();
  const std::size_t repaired = repairPath(points, world, config.repair_distance);
  checkPathFree(points, world);

  Trajectory traj;
  traj.dimensions = dims;
  traj.dt = config.sample_dt;
  traj.report.input_waypoints = input_waypoints;
  traj.report.repaired_waypoints = repaired;
  if (config.shortcut) points = shortcutPolyline(points, world, config.shortcut_clearance);
  points = keepAwayFromObstacles(points, world, config.clearance_target, 0.5, config.end_tolerance);
  // The push moves each 0.5 m piece on its own, to where its own clearance reaches the target; along a
  // mapped wall (voxel steps, scan noise) the pieces end up to 0.1 m apart sideways. A corner is rounded over
  // at most 45 % of its edges, so each such kink was a turn of ~0.2 m radius the vehicle crawled through
  // (bugtrap_1.0: 0.1 m/s along the neck and a wall, 4.4 1/m). Straighten what the push left wherever a
  // straight edge between two pushed points keeps the clearance they got, less a tenth of the target. The
  // path's own ends stay out of it: they may not have been pushed (a start 5 cm from a wall), and an edge
  // from there would be allowed their small clearance all along.
  if (config.clearance_target > 0 && config.shortcut && points.size() > 4) {
    std::vector<Vec3> inner(points.begin() + 1, points.end() - 1);
    inner = shortcutPolyline(inner, world, config.clearance_target, 0.1 * config.clearance_target);
    inner.insert(inner.begin(), points.front());
    inner.push_back(points.back());
    points = std::move(inner);
  }
  points = dropCollinear(points);
  const double radius = config.corner_radius < 0 ? limits.v_max / limits.omega_max : config.corner_radius;
  double braking_arc = 0.0;  // a braking lead-in's length
  if (config.initial_speed > 0 && config.initial_heading) {
    // The lead-in's corner needs the turn radius of the speed the vehicle has there, not of v_max: a replan
    // ahead near an obstacle starts slower, and at the full-speed radius (v_max / omega_max: 8 m for the
    // GART UAV) no lead-in fitted before the obstacle, so the plan started at rest and was refused
    // (gart_cluttered_2d: 7 refusals in one mission at 0.7-3.6 m/s).
    const double lead_radius =
        std::min(radius, std::max(config.initial_speed, 0.1 * limits.v_max) / (config.limit_fraction * limits.omega_max));
    const double climb = dims == 3 ? config.initial_vz / config.initial_speed : 0.0;
    // When nothing fits at speed: a stop along the heading at the lead-in's deceleration, with some slack for the
    // vehicle's lag behind its reference.
    const double path_speed = dims == 3 ? std::hypot(config.initial_speed, config.initial_vz) : config.initial_speed;
    const double stop = path_speed * path_speed / (2 * std::max(config.lead_in_decel, config.max_accel));
    // Below 0.1 m a stop is no lead-in: starting at rest overshoots the start by no more (the tracker flies such a
    // start from a moving vehicle below 0.5 m/s).
    const bool may_brake = config.lead_in_decel > 0 || stop <= config.short_braking_m;
    const double braking_length = may_brake && stop > 0.1 ? 1.25 * stop + 0.3 : 0.0;
    bool braking = false;
    // In 3-D the climb turns at the vertical acceleration: at the start's speed, over this radius; and a level start
    // from a climb is allowed only where the kink in vz leaves the vehicle no more than kVerticalKinkM off.
    const double a_vz = config.limit_fraction * config.max_vertical_accel;
    const double vertical_radius = dims == 3 ? path_speed * path_speed / a_vz : 0.0;
    const bool level_allowed = dims != 3 || verticalKinkDeviation(config.initial_vz, a_vz) <= kVerticalKinkM;
    points = leadIn(points, *config.initial_heading, climb, level_allowed, std::max(2 * radius, 1.0), lead_radius, vertical_radius, braking_length,
                    config.clearance_target, world, config.shortcut_clearance, config.lead_in_path, traj.report.lead_in_failure, braking,
                    traj.report.lead_in_along_flown);
    if (braking) braking_arc = traj.report.lead_in_braking = braking_length;
  }
  traj.report.shortcut_waypoints = points.size();

  Corners corners = makeCorners(points, radius, world, config.clearance_target);
  // A braking lead-in stops at its corner and turns there in place: a rounded corner would start bending (and
  // cutting it) from the start, at speed.
  if (braking_arc > 0 && corners.size.size() > 2) corners.size[1] = 0.0;
  const double step = std::min(0.05, world.checkResolution());

  for (int iteration = 0;; ++iteration) {
    BSpline spline = makeSpline(corners);
    std::vector<CurvePoint> pts = sampleCurve(spline, step);
    std::map<int, Vec3> bad = collidingSpans(spline, pts, world);

    if (bad.empty()) {
      if (config.initial_heading) {
        // Turn in place first: a zero-length interval at the start that only changes the heading.
        CurvePoint start = pts.front();
        const double turn = wrapAngle(pts.front().heading - *config.initial_heading);
        const double shift = *config.initial_heading + turn - pts.front().heading;
        for (auto& p : pts) p.heading += shift;
        start.heading = *config.initial_heading;
        if (std::abs(turn) > 1e-9) pts.insert(pts.begin(), start);
        traj.initial_turn = turn;
      }
      const Profile prof = timeParametrise(pts, limits, dims, config, braking_arc);
      // Bounded before the samples are allocated: a duration the profile should never give (a crawl is refused below).
      constexpr double kMaxSamples = 1e6;
      if (!(prof.time.back() / config.sample_dt <= kMaxSamples))
        fail("the time parametrisation gave " + std::to_string(prof.time.back()) + " s, more than " +
             std::to_string(static_cast<long>(kMaxSamples)) + " samples of " + std::to_string(config.sample_dt) + " s");
      traj.samples = sampleInTime(pts, prof, config.sample_dt);
      // Samples lie on chords between checked curve points; check them too, they are what gets flown.
      for (const auto& s : traj.samples) {
        if (world.isFree(s.position)) continue;
        // The curve point at the same arc length tells which span the sample belongs to.
        const auto at = std::lower_bound(prof.arc.begin(), prof.arc.end(), s.arc_length);
        const std::size_t idx = std::min<std::size_t>(static_cast<std::size_t>(at - prof.arc.begin()), pts.size() - 1);
        bad.emplace(spline.firstControlPoint(pts[idx].u), s.position);
      }
      if (bad.empty()) {
        traj.curve = std::move(spline);
        traj.report.fallback_iterations = iteration;
        traj.report.shortcut_waypoints = corners.points.size();
        fillReport(traj, world, config.compute_clearance);
        if (const auto crawl = findCrawl(traj, limits)) fail("the smoothed trajectory crawls " + *crawl);
        return traj;
      }
      traj.samples.clear();
    }
    if (iteration + 1 >= config.max_fallback_iterations)
      fail("the smoothed path still collides near " + fmt(bad.begin()->second, dims) + " after " +
           std::to_string(config.max_fallback_iterations) + " rounds of corner tightening");

    // Fall back locally: tighten the corners that shape a colliding span, pulling the curve onto the free
    // polyline; where the curve already is the polyline, push the polyline away from the obstacle.
    const int corner_count = static_cast<int>(corners.points.size());
    std::set<int> to_tighten;
    std::vector<Vec3> to_push;
    for (const auto& [first, hit] : bad) {
      // Where the polyline itself is blocked next to the colliding point (a graze its edge check stepped over),
      // tightening does not help: the curve is pulled onto a blocked polyline, and rounds of it left sharp corners the
      // vehicle had to slow down for (r3d_128: 17 rounds, then a refusal). The polyline is pushed at once.
      if (polylineBlockedNear(corners.points, hit, world)) {
        to_push.push_back(hit);
        continue;
      }
      bool shaped_by_corner = false;
      for (int j = first; j <= first + BSpline::kDegree; ++j) {
        const int k = cornerOfControlPoint(j, corner_count);
        if (k > 0 && k < corner_count - 1 && corners.size[k] > 0.0) to_tighten.insert(k), shaped_by_corner = true;
      }
      if (!shaped_by_corner) to_push.push_back(hit);
    }
    for (int k : to_tighten) corners.size[k] = corners.size[k] < 1e-4 ? 0.0 : 0.5 * corners.size[k];
    for (const Vec3& hit : to_push)
      if (!pushPolylineAway(corners, hit, world, radius))
        fail("the path passes too close to an obstacle near " + fmt(hit, dims) +
             " and no local detour of up to 0.3 m is collision free");
  }
}

Trajectory smoothAfterBraking(const std::vector<planner::State>& path, const Trajectory& braking, const CollisionWorld& world,
                              const planner::VehicleLimits& limits, SmootherConfig config) {
  if (braking.samples.size() < 2) fail("the braking stretch has fewer than two samples");
  if (path.empty()) fail("the path is empty");
  for (const auto& s : braking.samples)
    if (!world.isFree(s.position)) fail("the braking stretch along the flown trajectory is blocked near " + fmt(s.position, world.dimensions()));
  const TrajectorySample& stop = braking.samples.back();
  std::vector<planner::State> way;
  auto add = [&](const Vec3& p) {
    if (way.empty() || (p - way.back().position).norm() > 0.05) {
      planner::State state;
      state.position = p;
      way.push_back(state);
    }
  };
  add(stop.position);
  // The way on from the stop: straight to the point of the path — one of its first vertices, or a point on its edges
  // half a metre apart, as far along it as the stop is from its start and 5 m more — that makes the whole way shortest,
  // the edge free and as clear as its ends (or shortcut_clearance). A path that turns back is joined near its start; one
  // that goes on past the stop is joined there, not after a way back to its start and a second turn.
  std::vector<Vec3> points;
  for (const auto& state : path) points.push_back(state.position);
  const std::vector<double> remaining = lengthToEnd(points);
  const double reach = stop.arc_length + 5.0;
  std::optional<std::pair<Vec3, std::size_t>> join;  // the point and the path vertex the path goes on from
  double best = std::numeric_limits<double>::infinity();
  const double stop_clearance = world.clearance(stop.position);
  auto consider = [&](const Vec3& at, std::size_t tail, double after) {
    const double total = (at - stop.position).norm() + after;
    if (total >= best || !world.isSegmentFree(stop.position, at) ||
        !planner::segmentClearanceAtLeast(world, stop.position, at, std::min({config.shortcut_clearance, stop_clearance, world.clearance(at)})))
      return;
    best = total, join = std::pair{at, tail};
  };
  double along = 0.0;
  for (std::size_t next = 1; next < points.size() && along <= reach; ++next) {
    const Vec3 from = points[next - 1], to = points[next];
    const double edge = (to - from).norm();
    for (double t = 0.5; t < edge; t += 0.5) consider(from + (to - from) * (t / edge), next, edge - t + remaining[next]);
    consider(to, next + 1, remaining[next]);
    along += edge;
  }
  if (join) {
    add(join->first);
    for (std::size_t i = join->second; i < points.size(); ++i) add(points[i]);
  } else {
    // Else back along the braking stretch (free: it is being flown), a point every half metre, to the path's start.
    double last_arc = stop.arc_length;
    for (auto it = braking.samples.rbegin(); it != braking.samples.rend(); ++it)
      if (last_arc - it->arc_length >= 0.5) add(it->position), last_arc = it->arc_length;
    add(braking.samples.front().position);
    for (const Vec3& p : points) add(p);
  }
  config.initial_speed = 0.0;
  config.initial_vz = 0.0;
  config.initial_heading = stop.heading;  // unwrapped: the samples after it continue the braking's heading
  config.lead_in_path.clear();
  const Trajectory rest = smoothPath(way, world, limits, config);

  Trajectory out = braking;
  out.dimensions = rest.dimensions;
  const double t0 = stop.time, s0 = stop.arc_length;
  // The smoothed trajectory's first sample is the stop itself, at rest.
  for (std::size_t i = 1; i < rest.samples.size(); ++i) {
    TrajectorySample sample = rest.samples[i];
    sample.time += t0;
    sample.arc_length += s0;
    out.samples.push_back(sample);
  }
  out.report = rest.report;
  out.report.length = out.length();
  out.report.duration = out.duration();
  out.report.lead_in_braking = s0;
  out.report.lead_in_along_flown = s0;
  out.report.max_speed = std::max(rest.report.max_speed, std::hypot(braking.samples.front().speed, braking.samples.front().vz));
  for (const auto& s : braking.samples) {
    out.report.max_curvature = std::max(out.report.max_curvature, std::abs(s.curvature));
    out.report.max_yaw_rate = std::max(out.report.max_yaw_rate, std::abs(s.yaw_rate));
    if (config.compute_clearance) out.report.min_clearance = std::min(out.report.min_clearance, world.clearance(s.position));
  }
  out.initial_turn = 0.0;
  return out;
}

}  // namespace ddsnav::tracker
