#pragma once
// A time-parametrised trajectory: samples at a fixed dt plus the analytic curve they were taken from.

#include "ddsnav/planner/scenario.hpp"

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace ddsnav::tracker {

using planner::Vec3;

// A clamped B-spline of degree 3: the curve passes through the first and last control points and is
// C2 everywhere. Knots are uniform in the interior, with multiplicity 4 at both ends.
struct BSpline {
  static constexpr int kDegree = 3;
  std::vector<Vec3> control_points;
  std::vector<double> knots;  // control_points.size() + 4 values, non-decreasing

  static BSpline clampedUniform(std::vector<Vec3> control_points);  // needs >= 4 control points

  double parameterMin() const { return knots[kDegree]; }
  double parameterMax() const { return knots[knots.size() - 1 - kDegree]; }
  int spanCount() const { return static_cast<int>(control_points.size()) - kDegree; }
  // Index of the first control point that influences parameter u (the span's control points are
  // first .. first + 3).
  int firstControlPoint(double u) const;

  Vec3 point(double u) const;
  // Position and its first and second derivatives with respect to u.
  void evaluate(double u, Vec3& position, Vec3& first, Vec3& second) const;
};

struct TrajectorySample {
  double time = 0.0;          // s from the start of the trajectory
  Vec3 position = Vec3::Zero();
  double heading = 0.0;       // rad, unwrapped: continuous along the trajectory, not limited to (-pi, pi]
  double speed = 0.0;         // forward (horizontal) speed v, m/s
  double yaw_rate = 0.0;      // omega, rad/s
  double vz = 0.0;            // vertical speed, m/s (0 in 2-D)
  double curvature = 0.0;     // signed horizontal curvature, 1/m (left turn positive)
  double arc_length = 0.0;    // m along the curve from its start

  // World-frame velocity (v cos(heading), v sin(heading), vz).
  Vec3 velocity() const;
};

// Numbers a reader wants to know about a trajectory (see docs/smoothing.md).
struct TrajectoryReport {
  std::size_t input_waypoints = 0;     // after removing duplicates
  std::size_t repaired_waypoints = 0;  // moved off obstacles or added to bridge an edge (SmootherConfig::repair_distance)
  std::size_t shortcut_waypoints = 0;  // corners after shortcutting (plus detours the fallback added)
  int fallback_iterations = 0;         // rounds of corner tightening the collision check asked for
  double length = 0.0;                 // m
  double duration = 0.0;               // s
  double max_curvature = 0.0;          // 1/m, horizontal
  double max_speed = 0.0;              // m/s
  double max_yaw_rate = 0.0;           // rad/s
  double max_vz = 0.0;                 // m/s
  double max_accel = 0.0;              // m/s^2, along the path, between samples
  double max_heading_jump = 0.0;       // rad between consecutive samples
  // Time the trajectory spends below a quarter of its top speed (horizontal and vertical together) between the first
  // and the last moment it is faster: corners the smoother could only tighten, where the vehicle nearly stops. 0 when
  // it never slows down in between; the start's acceleration and the end's braking do not count.
  double slow_s = 0.0;
  Vec3 slowest_at = Vec3::Zero();      // the slowest such sample's position (when slow_s > 0)
  double min_clearance = std::numeric_limits<double>::infinity();  // m, robot boundary to obstacles
  std::size_t samples_in_collision = 0;  // always 0 for a trajectory the smoother returns
  // A moving start (initial_speed > 0) whose lead-in at speed did not fit: why, for the longest and the shortest
  // length tried (and the braking lead-in, when that did not fit either: the trajectory then starts at rest); empty
  // otherwise.
  std::string lead_in_failure;
  // No lead-in fitted at speed, a braking one did: the start brakes to rest over this many metres — along its heading
  // (SmootherConfig::lead_in_decel, short_braking_m), or along the flown trajectory (smoothAfterBraking, which sets
  // lead_in_along_flown to the same length) —, turns in place and joins the path; 0 otherwise.
  double lead_in_braking = 0.0;
  // No straight lead-in fitted at speed, one along the flown trajectory did (SmootherConfig::lead_in_path): its metres.
  double lead_in_along_flown = 0.0;
};

struct Trajectory {
  int dimensions = 2;
  double dt = 0.05;                       // sample spacing in time (the last sample may be closer)
  std::vector<TrajectorySample> samples;  // strictly increasing time, first at 0
  BSpline curve;                          // the analytic form of the geometric path
  double initial_turn = 0.0;              // rad turned in place before driving (0 without a start heading)
  TrajectoryReport report;

  bool empty() const { return samples.empty(); }
  double duration() const { return samples.empty() ? 0.0 : samples.back().time; }
  double length() const { return samples.empty() ? 0.0 : samples.back().arc_length; }
  // The state at time t, linearly interpolated between samples (clamped to the ends).
  TrajectorySample at(double time) const;
};

// The time at which `trajectory` has covered arc length `s` (clamped to its ends); 0 for an empty one.
double timeAtArcLength(const Trajectory& trajectory, double s);

// The deceleration that stops from `speed` within `room` metres, kept between `comfortable` and `limit`: the
// comfortable one when it stops in time, harder when the room is short, never past the vehicle's limit (at the limit
// the stop may run past the room: it is what the vehicle can do).
double brakingDecel(double speed, double room, double comfortable, double limit);

// The rest of `trajectory` from `from_time`, driven from `speed` (m/s along the path) down to rest at a constant
// `decel` (m/s^2): the same path, retimed, so that a vehicle told to stop brakes along its checked path instead of
// coasting straight on (a UAV braking from 4.2 m/s leaves a curving trajectory by metres). Ends at rest where the
// speed reaches 0, or at the trajectory's end. Sampled every trajectory.dt. std::invalid_argument for an empty
// trajectory, a negative or non-finite speed or a decel that is not positive.
Trajectory brakeAlong(const Trajectory& trajectory, double from_time, double speed, double decel);

// Whether a vehicle arriving at `arrival_speed` (m/s, horizontal, as the samples' speed) at the start of `trajectory`
// cannot take it over. Not when it arrives slower than `flown_through` or the trajectory starts at most `slack` slower.
// Otherwise it cannot when the trajectory starts at rest (below `at_rest`: the vehicle would overshoot its start), or
// when the vehicle, braking at `max_decel` along the trajectory's arc until it is down to the trajectory's speed
// (within `slack`), would meet a stop of the trajectory or need more than `omega_max` for its curve on the way. The
// smoother starts a trajectory slower than the vehicle where a curve near the start cannot be reached from its speed
// (SmootherConfig::initial_speed); on a straight or gentle stretch the vehicle runs ahead on the path until its
// reference catches up, before a tight curve it turns at its limit and leaves the path (stunnel_0.5, 2026-12-06: a
// start at 1.6 m/s under 4.3 m/s, 0.9 m before a 0.18 1/m curve, 0.67 m off the path and 4 mm into a wall).
// In 3-D it also cannot where, on the way, the trajectory climbs or descends more steeply than `vz_max` allows at the
// vehicle's speed (terrain_ridge_3d, 2026-12-06: a start at 0.56 m/s climbing at 0.79 under a vehicle at 3.8 m/s,
// which could climb at 2 m/s, not the 3 m/s that slope needed: 0.72 m off the trajectory).
// The rule's speeds, m/s (the tracker component's too): a trajectory starting slower than kAtRestSpeed starts at rest; a
// vehicle reaching a start faster than kFlownThroughSpeed flies through it; a start at most kStartSpeedSlack slower is
// taken over without a look (about 6 cm ahead of the reference at 2 m/s^2).
inline constexpr double kAtRestSpeed = 0.1, kFlownThroughSpeed = 0.5, kStartSpeedSlack = 0.5;
bool cannotTakeOver(const Trajectory& trajectory, double arrival_speed, double max_decel, double omega_max,
                    double flown_through = kFlownThroughSpeed, double at_rest = kAtRestSpeed, double slack = kStartSpeedSlack,
                    double vz_max = std::numeric_limits<double>::infinity());
// cannotTakeOver's why: empty when the vehicle can take the trajectory over, else what it would meet and where.
std::string takeOverRefusal(const Trajectory& trajectory, double arrival_speed, double max_decel, double omega_max,
                            double flown_through = kFlownThroughSpeed, double at_rest = kAtRestSpeed, double slack = kStartSpeedSlack,
                            double vz_max = std::numeric_limits<double>::infinity());

}  // namespace ddsnav::tracker
