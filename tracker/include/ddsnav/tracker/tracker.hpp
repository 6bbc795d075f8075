#pragma once
// Follows a time-parametrised trajectory with the unicycle: computes velocity commands from the vehicle
// state, keeps tracking statistics, and says when a new plan is needed. See docs/tracking.md.

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/tracker/trajectory.hpp"
#include "ddsnav/tracker/vehicle.hpp"

#include <cstddef>
#include <limits>
#include <optional>
#include <memory>
#include <string>

namespace ddsnav::tracker {

enum class ControllerType {
  // Trajectory feedforward (v_r, omega_r) plus nonlinear feedback on the error in the vehicle frame
  // (Kanayama / de Luca-Oriolo form, gains scheduled on the reference). The default.
  FeedforwardFeedback,
  // Geometric pure pursuit on the path with the trajectory's speed profile; kept as the comparison.
  PurePursuit,
};

struct TrackerConfig {
  ControllerType controller = ControllerType::FeedforwardFeedback;
  // Feedback: with a = min(sqrt(omega_r^2 + b v_r^2), max_natural_frequency),
  // k_along = k_heading = 2 zeta a and k_lateral = (a^2 - omega_r^2) / v_r (= b v_r below the cap).
  double zeta = 0.7;             // damping ratio of the linearised error dynamics
  double b = 6.0;                // 1/m^2, lateral stiffness at low speed
  double max_natural_frequency = 2.5;  // rad/s, keeps the feedback within the turn-rate limit at speed
  double min_gain = 0.5;         // 1/s floor for k_along and k_heading when the reference is (nearly) at rest
  // The reference time stops advancing while the reference is more than max_lead metres (along the path)
  // ahead of the vehicle, so a vehicle held back (saturation, disturbance) is not left behind for good.
  double max_lead = 0.5;
  double lookahead_min = 0.6;    // m, pure pursuit
  double lookahead_time = 0.4;   // s of reference speed added to the pure pursuit lookahead
  double goal_tolerance = 0.1;   // m: goal reached when the reference is finished and the vehicle this close
  // m/s^2: the speed command never exceeds what still slows to the reference's speed wherever it slows ahead,
  // braking at this rate: v^2 <= v_j^2 + 2 a (s_j - s) for the samples j ahead of the vehicle's arc position s.
  // A vehicle behind its reference (a late switch to a new trajectory) was told to catch up at 2.4 m/s toward a
  // stop 2.3 m ahead next to a wall, and overshot it by 0.5 m into the wall (stunnel_1.0). The smoother's own
  // rate (SmootherConfig::max_accel): the reference obeys it, so the cap only bites on catching up. 0: no cap (the
  // tracker component's default in 3-D, where the missions took longer with it: docs/tracking.md).
  double catch_up_decel = 1.0;
  double replan_deviation = 1.0;      // m of cross-track error that asks for a new plan
  double replan_horizon = std::numeric_limits<double>::infinity();  // s of the remaining trajectory checked
  // m of the remaining trajectory (arc length from the reference) checked as well, whichever of the two
  // reaches farther: what the sensor can see is a distance, and at sea scale (2 m/s, a 200 m sonar) a time
  // horizon sized for the 2-D yard saw the shore 15 m ahead. 0: the time horizon alone.
  double replan_horizon_distance = 0.0;
};

struct TrackingStatus {
  double time = 0.0;                 // s since the trajectory started (vehicle clock)
  double reference_time = 0.0;       // s, where on the trajectory the reference is
  double cross_track_error = 0.0;    // m, signed, left of the path positive
  double along_track_error = 0.0;    // m, signed, vehicle ahead of the reference positive
  double heading_error = 0.0;        // rad, vehicle minus reference, wrapped
  double position_error = 0.0;       // m, distance to the reference point
  double mean_cross_track_error = 0.0;  // m, running mean of |cross_track_error|
  double max_cross_track_error = 0.0;   // m, running max of |cross_track_error|
  double mean_position_error = 0.0;     // m, running mean of position_error
  double progress = 0.0;             // fraction of the trajectory length covered, 0..1
  bool goal_reached = false;
  std::size_t updates = 0;
};

enum class ReplanReason { None, Deviation, TrajectoryBlocked };
const char* toString(ReplanReason reason);

struct ReplanDecision {
  bool needed = false;
  ReplanReason reason = ReplanReason::None;
  std::string message;         // human-readable, names the numbers
  Vec3 blocked_at = Vec3::Zero();  // first blocked sample, for TrajectoryBlocked
  double time_ahead = 0.0;         // TrajectoryBlocked: s of trajectory from the reference to that sample
  double penetration = 0.0;        // TrajectoryBlocked: m the robot overlaps the obstacle (-clearance), the
                                   // deepest along the blocked run from that sample (within the horizon)
};

// Where on `trajectory` the robot must have stopped to stay in space the map has observed free: the arc length of
// the last sample before the first one, at or after arc length `from_arc` and at most `reach` metres beyond it,
// where `observed_free` says the robot would not be (false); `from_arc` when that is the first sample looked at;
// infinity when there is none (a sample it cannot judge, nullopt, counts as observed). For
// TrajectoryTracker::limitToObservedSpace with planner::robotInObservedFreeSpace.
template <class ObservedFree>
double observedStopArc(const Trajectory& trajectory, double from_arc, double reach, ObservedFree&& observed_free) {
  double last_observed = from_arc;
  for (const TrajectorySample& sample : trajectory.samples) {
    if (sample.arc_length < from_arc) continue;
    if (sample.arc_length > from_arc + reach) break;
    const std::optional<bool> seen = observed_free(sample.position);
    if (seen && !*seen) return last_observed;
    last_observed = sample.arc_length;
  }
  return std::numeric_limits<double>::infinity();
}

class TrajectoryTracker {
 public:
  // Throws std::invalid_argument for an empty trajectory or bad limits / gains.
  TrajectoryTracker(Trajectory trajectory, const VehicleLimits& limits, const TrackerConfig& config = {});

  // One control step: advances the reference by dt, measures the errors against `state` and returns the
  // command (already saturated to the limits). After the goal is reached it returns zero commands.
  VehicleCommand update(const VehicleState& state, double dt);

  const TrackingStatus& status() const { return status_; }
  const Trajectory& trajectory() const { return *trajectory_; }
  const TrackerConfig& config() const { return config_; }

  // Whether the vehicle should ask for a new plan: cross-track error beyond replan_deviation, or a sample
  // of the remaining trajectory (within replan_horizon seconds or replan_horizon_distance metres of the
  // reference, whichever reaches farther) no longer free in `world` (new obstacles).
  // `min_horizon_s`: check at least this far ahead (the caller's planning time: a block found later than
  // a plan takes cannot be planned around ahead).
  ReplanDecision checkReplan(const planner::CollisionWorld& world, double min_horizon_s = 0.0) const;

  // Moves the reference forward to the vehicle's projection on the first `within_s` seconds of the
  // trajectory, up to its first stop (a turn in place is never skipped), when the vehicle is already past its start: a trajectory planned from a predicted start
  // that arrives late would otherwise begin behind the vehicle, and the controller would pull it back (a
  // deviation replan after every late switch). Returns the seconds skipped (0 when none).
  double skipToVehicle(const Vec3& position, double within_s);

  // Stopping within observed space (docs/tracking.md): from now on the speed command never exceeds what still
  // stops, braking at `decel`, by arc length `arc` of the trajectory — before the robot would enter space the
  // map has not observed free (observedStopArc), but never below `crawl_speed` (a stop from it is short: the space
  // ahead of a passage is seen only from its mouth). The reference waits for the vehicle meanwhile (max_lead).
  // infinity lifts the bound. std::invalid_argument for a NaN arc, a decel that is not positive and finite, or a
  // crawl speed that is negative or not finite.
  void limitToObservedSpace(double arc, double decel, double crawl_speed = 0.0);
  // The bound's arc length (infinity without one) and the speed it allows the vehicle where it is now.
  double observedSpaceArc() const { return observed_arc_; }
  double observedSpaceCap() const { return observed_cap_; }

 private:
  struct Projection {
    std::size_t segment = 0;  // samples[segment] .. samples[segment + 1]
    Vec3 point = Vec3::Zero();
    double arc_length = 0.0;
    double signed_distance = 0.0;
  };
  Projection project(const Vec3& position) const;
  // The speed from which the vehicle, braking at catch_up_decel, still reaches every sample ahead of its arc
  // position at no more than that sample's speed (infinity without a cap).
  double brakingCap(const Projection& proj) const;
  VehicleCommand feedforwardFeedback(const VehicleState& state, const TrajectorySample& ref) const;
  VehicleCommand purePursuit(const VehicleState& state, const Projection& proj) const;
  VehicleCommand approachGoal(const VehicleState& state) const;
  TrajectorySample sampleAtArcLength(double s) const;

  // Shared, never changed: a copy of the tracker (the replan check takes one per check, on a worker) does not
  // copy thousands of samples on the control thread.
  std::shared_ptr<const Trajectory> trajectory_;
  VehicleLimits limits_;
  TrackerConfig config_;
  TrackingStatus status_;
  std::size_t last_segment_ = 0;
  double observed_arc_ = std::numeric_limits<double>::infinity();
  double observed_decel_ = 1.0;
  double observed_crawl_ = 0.0;
  double observed_cap_ = std::numeric_limits<double>::infinity();  // the bound's speed at the last update
  double sum_cross_ = 0.0, sum_position_ = 0.0;
};

}  // namespace ddsnav::tracker
