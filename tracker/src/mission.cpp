#include "ddsnav/tracker/mission.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

namespace ddsnav::tracker {

const char* toString(MissionAction action) {
  switch (action) {
    case MissionAction::Wait: return "wait";
    case MissionAction::RequestPlan: return "request plan";
    case MissionAction::SmoothPath: return "smooth path";
    case MissionAction::Drive: return "drive";
    case MissionAction::CheckReplan: return "check replan";
    case MissionAction::Finished: return "finished";
    case MissionAction::Failed: return "failed";
  }
  return "?";
}

namespace {

MissionDecision just(MissionAction action) {
  MissionDecision d;
  d.action = action;
  return d;
}

std::int64_t secondsToNs(double s) { return static_cast<std::int64_t>(s * 1e9); }

std::string metres(double m) {
  char text[64];
  std::snprintf(text, sizeof text, "%.2f m", m);
  return text;
}

}  // namespace

GoalCheck checkGoal(const Vec3& goal, double radius, const std::optional<Vec3>& position) {
  GoalCheck out;
  if (!position || !position->allFinite()) {
    out.distance = std::numeric_limits<double>::infinity();
    out.why = "no vehicle position was received";
    return out;
  }
  out.distance = (*position - goal).norm();
  out.reached = out.distance <= radius;
  if (!out.reached)
    out.why = "the vehicle is " + metres(out.distance) + " from the goal, outside the " + metres(radius) + " goal region";
  return out;
}

GoalCheck Mission::goalCheck(const VehicleState& state) const {
  return checkGoal(config_.goal, config_.goal_radius, state.position);
}

Mission::Mission(const MissionConfig& config) : config_(config) {
  // The component checks its parameters with their names; this guards other callers.
  if (config_.max_plan_attempts < 1) throw std::invalid_argument("Mission: max_plan_attempts must be at least 1");
  if (!(config_.plan_retry_delay_s >= 0)) throw std::invalid_argument("Mission: plan_retry_delay_s must be >= 0");
  if (!(config_.refused_retry_delay_s >= 0)) throw std::invalid_argument("Mission: refused_retry_delay_s must be >= 0");
  if (!(config_.time_budget_s > 0)) throw std::invalid_argument("Mission: time_budget_s must be positive");
  if (!(config_.replan_check_period_s > 0)) throw std::invalid_argument("Mission: replan_check_period_s must be positive");
}

MissionDecision Mission::update(std::int64_t now_ns, const std::optional<VehicleState>& state, bool world_available,
                                const std::optional<PlanAnswer>& answer) {
  if (failure_) return fail(*failure_, "");
  if (finished_) return just(MissionAction::Finished);
  if (!state) return just(MissionAction::Wait);
  if (request_id_ == 0) {
    // The planner's world must exist before the first request (perception's first scan, the first map).
    if (config_.wait_for_world && !world_available) return just(MissionAction::Wait);
    return request(now_ns, *state, "start");
  }
  if (answer && answer->request_id == request_id_) {
    pending_since_ns_.reset();
    // A "solved" path that stops short of the goal region is no way to the goal: the planner's exact flag
    // and the path's own end must both say it gets there.
    const GoalCheck end = checkGoal(config_.goal, config_.goal_radius, answer->path_end);
    if (optional_ && !(answer->solved && answer->exact && end.reached))
      return dropOptional(now_ns, *state, "plan " + std::to_string(request_id_) + " (optional) found no route to the goal" +
                                              (answer->failure.empty() ? std::string() : ": " + answer->failure));
    if (!answer->solved) {
      std::string warning = "plan " + std::to_string(request_id_) + " failed";
      if (!answer->failure.empty()) warning += ": " + answer->failure;
      return retryLater(now_ns, "no plan after " + std::to_string(attempts_) + " attempts", std::move(warning));
    }
    if (!answer->exact || !end.reached) {
      std::string warning = "plan " + std::to_string(request_id_) + " is solved but does not reach the goal region: ";
      if (!answer->path_end) warning += "it has no states";
      else if (!end.reached) warning += "it ends " + metres(end.distance) + " from the goal (goal radius " + metres(config_.goal_radius) + ")";
      else warning += "the planner marks it approximate (exact = false)";
      return retryLater(now_ns, "no plan to the goal region after " + std::to_string(attempts_) + " attempts", std::move(warning));
    }
    MissionDecision d = just(MissionAction::SmoothPath);
    d.request_id = request_id_;
    return d;
  }
  return afterAnswer(now_ns, *state);
}

MissionDecision Mission::pathSmoothed(std::int64_t now_ns, const VehicleState& state, bool ok, bool retry_at_once) {
  if (optional_ && !ok) return dropOptional(now_ns, state, "");
  optional_ = false;
  if (!ok) {
    // The first refusal in a row is asked again after refused_retry_delay_s (0 here, 0.2 s in the component): a path refused
    // for a collision on the tracker's world (a newer map than the planner's) is most often planned anew on that map,
    // and the retry delay held such replans for a second of the mission (bugtrap_0.4, 2026-12-06: 2 of a mission's 6
    // replans). Further refusals in a row wait plan_retry_delay_s, so that the attempts are not used up in a moment.
    // A path refused for the vehicle's speed at its start (retry_at_once) waits for no map: asked again at once.
    const double delay_s = ++refusals_in_a_row_ == 1 ? (retry_at_once ? 0.0 : config_.refused_retry_delay_s) : config_.plan_retry_delay_s;
    return retryLater(now_ns, "no drivable trajectory after " + std::to_string(attempts_) + " attempts", "", delay_s);
  }
  refusals_in_a_row_ = 0;
  driving_ = true;
  attempts_ = 0;
  return afterAnswer(now_ns, state);
}

MissionDecision Mission::afterAnswer(std::int64_t now_ns, const VehicleState& state) {
  if (retry_at_ns_ && now_ns >= *retry_at_ns_) {
    retry_at_ns_.reset();
    return request(now_ns, state, "retrying");
  }
  // A request may be lost while the planner restarts: ask again after the answer timeout. Unanswered
  // requests count as attempts, so a missing planner ends the mission instead of being asked forever.
  if (pending_since_ns_ && static_cast<double>(now_ns - *pending_since_ns_) * 1e-9 > config_.answerTimeoutS()) {
    if (optional_) return dropOptional(now_ns, state, "plan " + std::to_string(request_id_) + " (optional): no answer from the planner");
    std::string warning = "plan " + std::to_string(request_id_) + ": no answer from the planner";
    if (attempts_ >= config_.max_plan_attempts)
      return fail("no answer from the planner (planning/path) after " + std::to_string(attempts_) + " attempts",
                  std::move(warning));
    MissionDecision d = request(now_ns, state, "no answer");
    d.warning = std::move(warning);
    return d;
  }
  // Checked after the lost-answer timeout: a vehicle flying the rest of its trajectory while a replan is
  // planned must not wait for an answer that never comes.
  if (driving_) return just(MissionAction::Drive);
  return just(MissionAction::Wait);
}

MissionDecision Mission::tracked(std::int64_t now_ns, const VehicleState& state, const TrackingStatus& status, double dt) {
  const GoalCheck goal = goalCheck(state);
  if (goal.reached && (status.goal_reached || status.progress > 0.95)) {
    finished_ = true;
    return just(MissionAction::Finished);
  }
  if (status.goal_reached) {
    // The controller is at the trajectory's end, the vehicle is not in the goal region: ask again from here.
    ++short_ends_;
    driving_ = false;
    const std::string why = "trajectory " + std::to_string(request_id_) + " ended but " + goal.why;
    if (short_ends_ >= config_.max_plan_attempts)
      return fail("goal not reached: " + std::to_string(short_ends_) + " trajectories ended outside the goal region; last: " + goal.why,
                  why);
    MissionDecision d = request(now_ns, state, "the last trajectory ended outside the goal region");
    d.warning = why;
    return d;
  }
  since_replan_check_ += dt;
  if (since_replan_check_ >= config_.replan_check_period_s) {
    since_replan_check_ = 0.0;
    return just(MissionAction::CheckReplan);
  }
  return just(MissionAction::Drive);
}

MissionDecision Mission::replan(std::int64_t now_ns, const VehicleState& state, const std::string& why) {
  driving_ = false;
  return request(now_ns, state, why);
}

MissionDecision Mission::replanAhead(std::int64_t now_ns, const VehicleState& predicted, const std::string& why) {
  return request(now_ns, predicted, why);
}

MissionDecision Mission::improveAhead(std::int64_t now_ns, const VehicleState& predicted, const std::string& why) {
  // Only while a trajectory is flown and nothing else is awaited: an optional request must not displace a required one.
  if (!driving_ || awaitingPlan() || finished_ || failure_) return just(MissionAction::Drive);
  return request(now_ns, predicted, why, /*optional=*/true);
}

MissionDecision Mission::dropOptional(std::int64_t now_ns, const VehicleState& state, std::string note) {
  optional_ = false;
  pending_since_ns_.reset();
  MissionDecision d = afterAnswer(now_ns, state);
  if (d.warning.empty()) d.note = std::move(note);
  return d;
}

MissionDecision Mission::request(std::int64_t now_ns, const VehicleState& from, std::string reason, bool optional) {
  optional_ = optional;  // a required request supersedes an optional one
  ++request_id_;
  if (!optional) ++attempts_;  // an optional one is no attempt: its failure changes nothing
  pending_since_ns_ = now_ns;
  retry_at_ns_.reset();  // this request supersedes a retry still waiting (a replan asked meanwhile)
  MissionDecision d = just(MissionAction::RequestPlan);
  d.request_id = request_id_;
  d.from = from;
  d.reason = std::move(reason);
  return d;
}

MissionDecision Mission::fail(std::string cause, std::string warning) {
  failure_ = cause;
  MissionDecision d = just(MissionAction::Failed);
  d.reason = std::move(cause);
  d.warning = std::move(warning);
  return d;
}

// A failed attempt (unsolved, or not smoothable): ask again after the retry delay (or `delay_s`), unless the attempts
// are used up.
MissionDecision Mission::retryLater(std::int64_t now_ns, const std::string& cause, std::string warning, std::optional<double> delay_s) {
  if (attempts_ >= config_.max_plan_attempts) return fail(cause, std::move(warning));
  retry_at_ns_ = now_ns + secondsToNs(delay_s.value_or(config_.plan_retry_delay_s));
  MissionDecision d = just(MissionAction::Wait);
  d.warning = std::move(warning);
  return d;
}

}  // namespace ddsnav::tracker
