#pragma once
// Turns a planner path (straight edges between states) into a smooth, time-parametrised trajectory that
// the unicycle can drive: shortcut, round the corners with a clamped cubic B-spline, time-parametrise under
// the vehicle limits, collision-check every sample and tighten corners that collide.
// See docs/smoothing.md for the method and why.

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/tracker/trajectory.hpp"

#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::tracker {

// Thrown for input the smoother cannot use and for paths it cannot make safe. what() says which state or
// edge and what was expected. No trajectory is returned in that case.
class SmoothingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SmootherConfig {
  double sample_dt = 0.05;       // s between trajectory samples
  // The trajectory uses this fraction of v_max, omega_max and vz_max; the rest is left to the tracker's
  // feedback so that it can correct errors without saturating.
  double limit_fraction = 0.85;
  double max_accel = 1.0;        // m/s^2 along the path
  double max_lateral_accel = std::numeric_limits<double>::infinity();  // m/s^2, v^2 * curvature
  // 3-D: m/s^2 on the vertical speed (the simulated vehicle's VehicleConfig::max_vertical_accel; this fraction of it
  // is used, limit_fraction). Where the climb changes along the curve the speed is capped so that vz follows at this
  // rate: a descent that turns into a climb within a metre, at full speed, left the vehicle 0.69 m below it.
  double max_vertical_accel = 2.0;
  bool shortcut = true;          // collision-checked shortcutting before smoothing
  // Shortcuts must keep at least this clearance (m) from obstacles; the planner's own edges are kept
  // as they are even when closer.
  double shortcut_clearance = 0.1;
  // Where the (shortcut) path runs closer than this to obstacles (m, from the robot's boundary), its points
  // are moved away, up to the middle of narrower passages, so that tracking errors stay off the walls.
  // 0 keeps the planner's geometry.
  double clearance_target = 0.2;
  // The tracker component's default for it (parameter clearance_target), which tools that replay its smoothing
  // (ddsnav-resmooth) take too: a vehicle flying a metre off the walls, where the library keeps 0.2 m.
  static constexpr double kTrackerClearanceTargetM = 1.0;
  // How far (m) the last point may be moved for clearance; e.g. the goal radius minus the end's distance
  // to the goal, so that it stays in the goal region. 0 keeps the end where the planner put it.
  double end_tolerance = 0.0;
  // Target turn radius at corners, m: < 0 means v_max / omega_max (corners at full speed when there is
  // room); 0 means no rounding: the polyline itself, stopping and turning in place at every corner.
  double corner_radius = -1.0;
  int max_fallback_iterations = 40;  // rounds of local repair: halve nearby corners, or detour the polyline
  // Heading the vehicle has at the start; when set, the trajectory starts by turning in place from it.
  std::optional<double> initial_heading;
  // Speed (m/s) the vehicle has at the start: a replan from a point ahead on the trajectory being flown
  // starts moving, so the new trajectory must not begin at rest (the vehicle would stop at every switch).
  // With initial_heading set, a straight lead-in along that heading is put first when it is collision free,
  // so the curve leaves the start tangent to the vehicle's heading and no turn in place is needed; where it
  // is not, the trajectory starts at rest with the turn. Where a curve near the start is too tight to be reached from
  // this speed at max_accel (or lead_in_decel along a braking lead-in), it starts slower, at what the curve allows: the
  // caller decides whether the vehicle can take that over (the tracker: not when, braking from its speed, it would reach
  // the curve too fast to turn). 0: start at rest.
  double initial_speed = 0.0;
  // Climb rate (m/s) the vehicle has at the start, 3-D: the lead-in follows the vehicle's climb first (a UAV
  // climbing a hillside at 15 deg found no level lead-in clear of the slope ahead, and each plan ahead started at
  // rest and was refused), then the level heading. Ignored in 2-D and at rest.
  double initial_vz = 0.0;
  // Deceleration (m/s^2) of a braking lead-in: when no lead-in fits at speed (the path turns back, or its corner is too
  // tight for the start's speed), the start brakes to rest straight along its heading, turns in place and joins the
  // path, instead of starting at rest where the vehicle arrives moving. 0 (the default): no braking lead-in. Below
  // max_accel, max_accel is used.
  double lead_in_decel = 0.0;
  // Without lead_in_decel, a braking lead-in at max_accel is still put first when its stop is at most this long (m): a
  // vehicle turning back in a corridor at 0.6-1.4 m/s stops within a metre anyway, and refusing the plan cost a round
  // trip and a retry delay before that stop (stunnel_0.5 at real time, 2026-12-06: 2 such refusals at 0.6 m/s in a
  // mission). Long stops stay refused: at 4 m/s the stop carries the vehicle 8 m on toward what it stops
  // for (docs/tracking.md). 0: only with lead_in_decel.
  double short_braking_m = 0.0;
  // The way the vehicle goes on from the start (a replan ahead: the trajectory it flies, from the start on; the start
  // first): when no straight lead-in along initial_heading fits, a lead-in along this is tried, of the same lengths,
  // before the braking one. In a narrow passage the vehicle's heading is a few degrees off its axis where the trajectory
  // curves, and every straight lead-in came too close to a wall (bugtrap_0.4: three stops to plan at rest in one
  // mission's neck). Empty: straight lead-ins only.
  std::vector<Vec3> lead_in_path;
  // A path state the world finds in collision is moved to the nearest free position within this distance (m) (the start
  // too: the trajectory then begins that far from the vehicle), or left out when it lies deeper (not the start, not the
  // last), and an edge it finds blocked between free states is bridged through the nearest free position to the middle of its stretch in collision, or else goes the lattice route round (within 20 ms),
  // instead of the path being refused: the smoother's world is not the planner's (it may be built from a newer map, and
  // it is seen from the path's start). What stays in collision is refused as before. 0: refuse at once.
  double repair_distance = 0.0;
  bool compute_clearance = true;     // fill report.min_clearance (one clearance query per sample)
};

// Throws SmoothingError (bad path, bad limits, start in collision, cannot be made collision free).
Trajectory smoothPath(const std::vector<planner::State>& path, const planner::CollisionWorld& world,
                      const planner::VehicleLimits& limits, const SmootherConfig& config = {});

// A plan that cannot be flown through at speed (no lead-in fits where the vehicle arrives moving: the path turns back,
// or its first corner is too tight), flown without refusing it: `braking` — the trajectory being flown from the plan's
// start, braked to rest along itself (brakeAlong) — then, from where it comes to rest, `path` smoothed from rest with
// the vehicle's heading there: back along the braking stretch to the path's start and on along the path, shortcut
// where that is free. One trajectory: the braking's samples, then the smoothed ones; its report is the smoothed path's
// with the braking's length and time added and `lead_in_braking` set to the braking's length. Throws SmoothingError
// as smoothPath does, and when the braking stretch is not free in `world` or has fewer than two samples.
Trajectory smoothAfterBraking(const std::vector<planner::State>& path, const Trajectory& braking, const planner::CollisionWorld& world,
                              const planner::VehicleLimits& limits, SmootherConfig config);

// Where the trajectory crawls: below 1 cm/s for more than 5 s while not turning in place (a cusp the time
// parametrisation turned into a near stop; on stunnel_0.5 a 148 m trajectory took 298 s, the vehicle standing at its
// start until the mission's timeout). smoothPath refuses such a trajectory with this text. Nothing when it does not.
std::optional<std::string> findCrawl(const Trajectory& trajectory, const planner::VehicleLimits& limits);

// The collision-checked shortcutting step on its own: the returned polyline keeps the first and last
// point, and each of its edges is either an edge of the input or free with a clearance of at least the
// smallest of `min_clearance` and its two ends' clearances, less `tolerance`.
std::vector<Vec3> shortcutPolyline(const std::vector<Vec3>& points, const planner::CollisionWorld& world,
                                   double min_clearance, double tolerance = 0.0);

}  // namespace ddsnav::tracker
