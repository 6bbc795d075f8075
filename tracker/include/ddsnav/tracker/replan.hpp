#pragma once
// When a blocked trajectory is worth a new plan, and where that plan should start (docs/tracking.md,
// "Replanning"). Pure logic over TrajectoryTracker::checkReplan results; the tracker component feeds it
// every check and carries out its verdict.
//
//   ReplanGate gate(policy);
//   auto verdict = gate.check(tracker.checkReplan(world), tracker.trajectory(), tracker.status().reference_time);
//   switch (verdict.action) { Continue: drive on; ReplanAhead: request from verdict.start, keep driving;
//                             StopAndReplan: stop, request from the vehicle's state; }
//   gate.planReady(seconds from request to trajectory);   // refines the expected planning time
//
// Rules:
//   - Deviation (cross-track error beyond the threshold): StopAndReplan at once.
//   - A blocked sample within the horizon counts only when it is blocked in confirm_checks consecutive
//     checks (hysteresis against a grazing ellipsoid refit or a noisy voxel), or at once when the robot
//     there would overlap the obstacle by more than block_margin (a real obstacle, not a graze).
//   - A confirmed block far enough ahead (more than the expected planning time + stop_margin) is replanned
//     from where the vehicle will be when the plan is ready: the trajectory's sample at reference time +
//     expected planning time. The vehicle keeps flying the still-valid part meanwhile. Closer than that, it
//     stops and replans from where it is.
//   - Expected planning time: max(planning_time_s, 1.25 x the second longest of the last 8 measured ones — the
//     longest while there is one): one outlier does not turn the next eight replans into stops.

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/tracker/tracker.hpp"
#include "ddsnav/tracker/trajectory.hpp"

#include <deque>
#include <optional>
#include <string>

namespace ddsnav::tracker {

struct ReplanPolicy {
  int confirm_checks = 5;           // consecutive blocked checks that confirm a block (>= 1); 0.5 s at 10 Hz
  // Consecutive blocked checks that confirm a block too near to plan ahead of (the vehicle stops for it), at most
  // confirm_checks. Half a second at 5 m/s is 2.5 m of a stopping distance of 6.25 m (gart_cluttered_2d: a block
  // first seen 1 s ahead was confirmed 0.54 s ahead, too late to stop before it).
  int near_confirm_checks = 2;
  double block_margin = 0.2;        // m of overlap that confirms a block at the first check
  double stop_margin_s = 1.5;       // s kept between the predicted start and the blocked sample
  double planning_time_s = 0.3;     // s, the least expected time from request to trajectory

  void validate() const;  // std::invalid_argument naming the field
};

enum class ReplanAction { Continue, ReplanAhead, StopAndReplan };
const char* toString(ReplanAction action);

struct ReplanVerdict {
  ReplanAction action = ReplanAction::Continue;
  TrajectorySample start;   // ReplanAhead: the predicted start (on the current trajectory)
  std::string reason;       // ReplanAhead / StopAndReplan: "<deviation|trajectory_blocked>: ..."
};

class ReplanGate {
 public:
  explicit ReplanGate(const ReplanPolicy& policy = {});

  // One check of the trajectory being flown; `reference_time` is the tracker's (status().reference_time).
  ReplanVerdict check(const ReplanDecision& decision, const Trajectory& trajectory, double reference_time);
  // A new trajectory is being flown: the hysteresis starts over.
  void reset() { blocked_checks_ = 0; }
  // Seconds from a request to its trajectory (planning + smoothing), measured by the caller.
  void planReady(double seconds);
  double expectedPlanningTime() const;
  int blockedChecks() const { return blocked_checks_; }

 private:
  ReplanPolicy policy_;
  int blocked_checks_ = 0;
  std::deque<double> latencies_;
};

// When to ask for a shorter route while the vehicle flies a trajectory that is not blocked (docs/tracking.md, "Shorter
// routes"). A replan for a block answers with the planner's first solution, since its latency counts; in 3-D the
// first solution of a world seen from one place is a detour of 30-70 % at times (random 3-D worlds, seeds 67 and 69:
// 1.72x and 1.70x the oracle, 2026-12-06), and the map grows as the vehicle flies. An optional request from a start
// ahead on the trajectory, with time to improve the first solution, is taken only when its trajectory gets to the goal
// sooner by min_gain than what is left of the one flown: a first solution is often as long as a better one but curvier,
// and its trajectory slower (random 3-D world 87: the last trajectory alone took 28.8 s, the oracle's whole one 26.4 s).
struct ImprovementPolicy {
  double every_s = 4.0;          // s of mission time between two asks at least; 0: never
  double min_gain = 0.1;         // share of the remaining time a new route must save to be taken
  double min_saving_s = 1.0;     // and at least this many seconds: near the goal a switch is not worth its risk
  int max_backoff = 8;           // each ask that brings nothing doubles the interval, up to every_s x this
  double wall_duty = 0.25;       // the asks' wall time (request to answer) stays under this share of the wall time

  void validate() const;  // std::invalid_argument naming the field
};

class ImprovementGate {
 public:
  explicit ImprovementGate(const ImprovementPolicy& policy = {});

  // Whether to ask now. `now_s`: mission time; `wall_s`: wall time (steady clock) in seconds; `remaining_s`: the time
  // left to fly from the predicted start to the goal (trajectory and the path after it); `least_s`: a lower bound of
  // any route's (the straight distance to the goal region at top speed). No ask where no route could save min_gain.
  bool due(double now_s, double wall_s, double remaining_s, double least_s) const;
  // An ask was sent at these times.
  void asked(double now_s, double wall_s);
  // Its outcome, settled at wall time `wall_s` (smoothed or dropped): `taken` (a shorter route is flown) resets the
  // interval, otherwise it doubles up to the cap.
  void answered(bool taken, double wall_s);
  // A new trajectory from a required plan (a replan's first solution): asking again is due one interval after it.
  void newTrajectory(double now_s);
  // Whether a route taking `offered_s` is worth taking over `remaining_s` left of the current one.
  bool worthTaking(double remaining_s, double offered_s) const {
    return offered_s < (1.0 - policy_.min_gain) * remaining_s && remaining_s - offered_s >= policy_.min_saving_s;
  }
  double interval() const { return policy_.every_s * backoff_; }
  const ImprovementPolicy& policy() const { return policy_; }

 private:
  ImprovementPolicy policy_;
  int backoff_ = 1;
  double last_ask_s_ = -1e300, last_ask_wall_s_ = -1e300, last_wall_latency_s_ = 0.0;
};

// The heading a vehicle at rest asks its plan from. It can turn in place before it drives, but a planner's
// kinodynamic tree grows from the start only within its turn limit of the start heading (GART's UAV: 36
// degrees an edge, edges up to 5 m): facing a wall — stopped at a dead end, or in a corner it ran wide of —
// every edge ends in the wall and no plan is found (stunnel_0.5: ten plans in a row from a corner, 1.3 million
// iterations each, then the mission gave up). `heading` itself while at least `min_free` metres straight ahead
// are free; otherwise, of 16 directions, the one with the least turn from it that has `min_free` metres free
// (the natural way on out of a corner, not the longest way back), or failing that the one with the most free
// space. Free space along a direction is counted from where it leaves collision, within `reach` (at least the robot
// radius: a vehicle that stopped touching a wall; a 3-D map's widened terrain buries a vehicle resting near a flank
// deeper, and the planner searches its start within the radius plus that margin). Directions are horizontal in 2-D; in
// 3-D a heading also counts as free climbing at 15, 30 or 45 degrees or descending at 15: a vehicle resting 0.6 m
// above a 28-degree flank, facing up it, was turned round to fly away downhill and back (a random world, seed 62: 1.75x
// and 1.95x the oracle; 1.62x with this rule), where it can climb as it sets off.
double restStartHeading(const planner::CollisionWorld& world, const Vec3& position, double heading, double min_free,
                        double reach = 0.0);
// The room restStartHeading asks for: max(1 m, 4 robot radii) — a few of the planner's shortest useful edges —
// doubled for each plan that failed before this one since the last trajectory, up to 8 times. Why: the base room
// is less than one edge of a fast vehicle's tree (GART's UAV: up to 5 m); bugtrap_0.4, a vehicle stopped 1.5 m
// below a wall and 3.4 m short of another, kept its heading (2.9 m of room ahead) and failed three plans in a row,
// 0.8 million iterations each, until the mission gave up.
double restStartRoom(double robot_radius, std::int64_t failed_plans);

// A vehicle meant to be flying that does not move: the net under states no other rule foresaw. It stalled when, for
// `stall_s` of mission time in a row, it was meant to fly (a trajectory to follow, no stop under way, no required plan
// awaited), stayed within `radius_m` of where that stretch began and turned by less than `turn_rad` (turning in place
// is moving). The tracker then stops and plans from rest (reason `stalled`). Why: a bugtrap_0.4 run with an
// experimental 2-D rule (not kept, 2026-12-07) stood 120 s at a trajectory's end with the rest of its path never
// smoothed, asking only optional plans, until the monitor's timeout: a mission ends by reaching its goal or with a
// reason, never by standing still.
struct StallPolicy {
  double stall_s = 6.0;     // mission seconds; 0: never (the longest legitimate rest while flying is a turn in place,
                            // which counts as moving, or a next trajectory's switch wait, a few tenths of a second)
  double radius_m = 0.2;    // moved less than this
  double turn_rad = 0.35;   // and turned less than this (20 degrees)

  void validate() const;  // std::invalid_argument naming the field
};

class StallWatch {
 public:
  explicit StallWatch(const StallPolicy& policy = {});
  // Every control step. `meant_to_fly`: see StallPolicy. True once when the vehicle has stalled; it then watches
  // afresh from this step. A step not meant to fly ends the stretch.
  bool update(double now_s, const Vec3& position, double heading, bool meant_to_fly);
  void reset() { since_s_.reset(); }
  const StallPolicy& policy() const { return policy_; }

 private:
  StallPolicy policy_;
  std::optional<double> since_s_;
  Vec3 anchor_ = Vec3::Zero();
  double anchor_heading_ = 0.0;
};

}  // namespace ddsnav::tracker
