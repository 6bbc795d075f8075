#pragma once
// The tracker component's mission logic, without DDS: when to ask the planner for a plan (at the start,
// after a failure, after a lost request, when a replan is needed), how many attempts to allow, when the
// goal region is reached and when to give up. The component feeds it plain inputs (time, vehicle state,
// the answer to a request, whether smoothing worked, the tracking status) and carries out its decisions
// (publish a request, smooth, drive, stop). See docs/tracking.md, "Mission".

#include "ddsnav/tracker/tracker.hpp"
#include "ddsnav/tracker/vehicle.hpp"

#include <cstdint>
#include <cmath>
#include <optional>
#include <string>

namespace ddsnav::tracker {

struct MissionConfig {
  Vec3 goal = Vec3::Zero();
  double goal_radius = 0.0;            // m, the scenario's goal region
  std::int64_t max_plan_attempts = 10; // requests (answered or not) without a drivable trajectory before giving up
  double plan_retry_delay_s = 1.0;     // s between a failed plan (or a second refused path in a row) and the next request
  double refused_retry_delay_s = 0.0;  // s between the first path in a row that could not be smoothed and the next request
                                       // (the component's default: 0.2 s, a map period)
  double time_budget_s = 5.0;          // s the planner may take per request
  double replan_check_period_s = 0.5;  // s of driving between two replan checks
  bool wait_for_world = true;          // no first request before the planner's world exists

  // Simulated seconds per wall second of the clock the mission runs on (1 on wall time). The planner's
  // time budget is wall time, so on a sped-up clock its answer takes `clock_speed` times longer in
  // the mission's seconds; the component measures it and keeps it current (Mission::setClockSpeed).
  double clock_speed = 1.0;
  // A request unanswered this long (mission clock) counts as lost (e.g. the planner restarted): twice the
  // budget + 2 s of wall time.
  double answerTimeoutS() const { return (2 * time_budget_s + 2) * clock_speed; }
};

// The planner's answer to a request (planning/path), reduced to what the mission decides on.
struct PlanAnswer {
  std::uint32_t request_id = 0;
  bool solved = false;
  std::string failure;  // the planner's reason when not solved (may be empty)
  bool exact = false;   // Path.exact: the planner says its last state is within the goal radius
  std::optional<Vec3> path_end;  // the path's last state; none when it has no states
};

// The one goal test behind every claim of success (the tracker's Finished, the monitor's goal_reached):
// the vehicle's true position — the simulator's vehicle/state, not where a trajectory ends — within
// `radius` of `goal`. No position (none heard yet) is not reached.
struct GoalCheck {
  bool reached = false;
  double distance = 0.0;  // m from the goal; +inf without a position
  std::string why;        // when not reached, e.g. "the vehicle is 38.00 m from the goal, outside the 1.50 m goal region"
};
GoalCheck checkGoal(const Vec3& goal, double radius, const std::optional<Vec3>& position);

enum class MissionAction {
  Wait,         // nothing to do this control period
  RequestPlan,  // publish a plan request `request_id` from `from`, for `reason`
  SmoothPath,   // the answer to the current request is a path: smooth it, then call pathSmoothed()
  Drive,        // step the trajectory tracker, then call tracked()
  CheckReplan,  // check the trajectory against the current world; if a replan is needed, call replan()
  Finished,     // goal reached: stop and keep reporting it
  Failed,       // give up: `reason` names the cause
};
const char* toString(MissionAction action);

struct MissionDecision {
  MissionAction action = MissionAction::Wait;
  std::uint32_t request_id = 0;  // RequestPlan: the new request; SmoothPath: the answered request
  VehicleState from;             // RequestPlan: the start state of the request
  std::string reason;            // RequestPlan: why ("start", "retrying", ...); Failed: the cause
  std::string warning;           // to be logged as a warning before acting, when not empty
  std::string note;              // to be logged as information (an optional plan not used), when not empty
};

class Mission {
 public:
  explicit Mission(const MissionConfig& config);

  // Once per control period. `state`: the latest vehicle state (none before the first one); `answer`: a
  // path received since the last call, if any. Answers to other requests than the current one are ignored
  // (so is any answer while there is no vehicle state). A solved answer that does not end in the goal
  // region (not exact, or its last state farther than goal_radius from the mission's goal) is a failed
  // attempt like an unsolved one: driving it to its end would not reach the goal. Returns Wait,
  // RequestPlan, SmoothPath, Drive, Finished or Failed.
  MissionDecision update(std::int64_t now_ns, const std::optional<VehicleState>& state, bool world_available,
                         const std::optional<PlanAnswer>& answer);

  // After SmoothPath: whether the path became a trajectory (which the caller now follows). Success resets the
  // attempt count and continues as update() would (normally Drive); failure retries after refused_retry_delay_s the
  // first time in a row (at once with `retry_at_once`: a refusal that no newer map explains) and after the delay the
  // next times, or gives up after max_plan_attempts.
  MissionDecision pathSmoothed(std::int64_t now_ns, const VehicleState& state, bool ok, bool retry_at_once = false);

  // After Drive, with the tracker's status after the step of `dt` seconds: Finished when the vehicle is in
  // the goal region (checkGoal) at the trajectory's end (the controller finished, or progress > 0.95).
  // The end of the trajectory with the vehicle outside the goal region is no success: a new request from
  // `state` (RequestPlan, with a warning saying how far the vehicle is), and after max_plan_attempts such
  // ends the mission fails. Otherwise CheckReplan once every replan_check_period_s of driving, else Drive.
  MissionDecision tracked(std::int64_t now_ns, const VehicleState& state, const TrackingStatus& status, double dt);

  // The replan check said a new plan is needed: stop following and ask from `state`.
  MissionDecision replan(std::int64_t now_ns, const VehicleState& state, const std::string& why);
  // A new plan from `predicted`, where the vehicle will be on its trajectory when the plan is ready
  // (ReplanGate): the vehicle keeps driving the current trajectory (Drive) until the answer is smoothed
  // (SmoothPath, then pathSmoothed() switches to it). A lost or failed answer is retried as usual.
  MissionDecision replanAhead(std::int64_t now_ns, const VehicleState& predicted, const std::string& why);
  // An optional plan from `predicted` while the vehicle flies on (a shorter route, ImprovementGate): it counts as no
  // attempt, and its failure (unsolved, not to the goal, not smoothed, or lost) changes nothing — no retry, the vehicle
  // flies on. A required request (any other) supersedes it; while it is pending awaitingPlan() is true and
  // awaitingRequiredPlan() is not.
  MissionDecision improveAhead(std::int64_t now_ns, const VehicleState& predicted, const std::string& why);
  // Stop driving, keep waiting for the current request (the block came too close while it was planned).
  void hold() { driving_ = false; }
  // The clock's measured speed (MissionConfig::clock_speed); ignored unless a finite number >= 1e-3.
  void setClockSpeed(double simulated_per_wall_second) {
    if (std::isfinite(simulated_per_wall_second) && simulated_per_wall_second >= 1e-3) config_.clock_speed = simulated_per_wall_second;
  }
  // A request is unanswered or a retry is due: no new replan is asked for meanwhile.
  bool awaitingPlan() const { return pending_since_ns_.has_value() || retry_at_ns_.has_value(); }
  // A failed attempt's retry is due (update() asks it): a caller that calls update() only on news, such as a
  // vehicle braking to the rest point its replan starts from, calls it for this too.
  bool retryDue(std::int64_t now_ns) const { return retry_at_ns_ && now_ns >= *retry_at_ns_; }
  // As awaitingPlan(), but an optional request (improveAhead) does not count: a replan may supersede it.
  bool awaitingRequiredPlan() const { return awaitingPlan() && !optional_; }
  // The current request is an optional one (improveAhead) not yet answered or smoothed.
  bool improving() const { return optional_; }

  // checkGoal for the mission's goal region.
  GoalCheck goalCheck(const VehicleState& state) const;

  const MissionConfig& config() const { return config_; }
  std::uint32_t requestId() const { return request_id_; }  // 0: nothing requested yet
  std::int64_t attempts() const { return attempts_; }       // requests since the last drivable trajectory
  bool driving() const { return driving_; }
  bool finished() const { return finished_; }

 private:
  MissionDecision request(std::int64_t now_ns, const VehicleState& from, std::string reason, bool optional = false);
  MissionDecision fail(std::string cause, std::string warning);
  MissionDecision retryLater(std::int64_t now_ns, const std::string& cause, std::string warning,
                             std::optional<double> delay_s = std::nullopt);
  MissionDecision afterAnswer(std::int64_t now_ns, const VehicleState& state);
  // The optional request's answer is not used: nothing changes, the vehicle flies on.
  MissionDecision dropOptional(std::int64_t now_ns, const VehicleState& state, std::string note);

  MissionConfig config_;
  std::uint32_t request_id_ = 0;
  std::int64_t attempts_ = 0;
  int refusals_in_a_row_ = 0;                     // paths not smoothed since the last drivable trajectory
  std::optional<std::int64_t> retry_at_ns_;      // a failed attempt waiting for its retry
  std::optional<std::int64_t> pending_since_ns_; // the current request, not answered yet
  bool driving_ = false;
  bool finished_ = false;
  std::optional<std::string> failure_;
  double since_replan_check_ = 0.0;  // s of driving since the last replan check
  std::int64_t short_ends_ = 0;      // trajectories that ended with the vehicle outside the goal region
  bool optional_ = false;            // the current request is optional (improveAhead) and not settled yet
};

}  // namespace ddsnav::tracker
