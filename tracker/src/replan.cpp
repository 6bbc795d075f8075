#include "ddsnav/tracker/replan.hpp"

#include "ddsnav/tracker/vehicle.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iterator>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace ddsnav::tracker {

const char* toString(ReplanAction action) {
  switch (action) {
    case ReplanAction::Continue: return "continue";
    case ReplanAction::ReplanAhead: return "replan ahead";
    case ReplanAction::StopAndReplan: return "stop and replan";
  }
  return "?";
}

void ReplanPolicy::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("replan policy: ") + what);
  };
  require(confirm_checks >= 1, "confirm_checks must be at least 1");
  require(near_confirm_checks >= 1, "near_confirm_checks must be at least 1");
  require(std::isfinite(block_margin) && block_margin >= 0, "block_margin must be a finite number of metres >= 0");
  require(std::isfinite(stop_margin_s) && stop_margin_s >= 0, "stop_margin_s must be a finite number of seconds >= 0");
  require(std::isfinite(planning_time_s) && planning_time_s >= 0, "planning_time_s must be a finite number of seconds >= 0");
}

void ImprovementPolicy::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("improvement policy: ") + what);
  };
  require(std::isfinite(every_s) && every_s >= 0, "every_s must be a finite number of seconds >= 0");
  require(min_gain >= 0 && min_gain < 1, "min_gain must be in [0, 1)");
  require(std::isfinite(min_saving_s) && min_saving_s >= 0, "min_saving_s must be a finite number of seconds >= 0");
  require(max_backoff >= 1 && max_backoff <= 1024, "max_backoff must be in [1, 1024]");
  require(wall_duty > 0 && wall_duty <= 1, "wall_duty must be in (0, 1]");
}

ImprovementGate::ImprovementGate(const ImprovementPolicy& policy) : policy_(policy) { policy_.validate(); }

bool ImprovementGate::due(double now_s, double wall_s, double remaining_s, double least_s) const {
  if (policy_.every_s <= 0 || !std::isfinite(remaining_s) || !std::isfinite(least_s)) return false;
  if (now_s - last_ask_s_ < interval()) return false;
  // The last ask kept the planner busy for its latency: the next waits until that is wall_duty of the time since.
  if (wall_s - last_ask_wall_s_ < last_wall_latency_s_ / policy_.wall_duty) return false;
  return (1.0 - policy_.min_gain) * remaining_s > least_s && remaining_s - least_s >= policy_.min_saving_s &&
         policy_.min_gain * remaining_s >= policy_.min_saving_s;
}

void ImprovementGate::asked(double now_s, double wall_s) {
  last_ask_s_ = now_s;
  last_ask_wall_s_ = wall_s;
}

void ImprovementGate::answered(bool taken, double wall_s) {
  backoff_ = taken ? 1 : std::min(2 * backoff_, policy_.max_backoff);
  if (const double latency = wall_s - last_ask_wall_s_; std::isfinite(latency) && latency >= 0) last_wall_latency_s_ = latency;
}

void ImprovementGate::newTrajectory(double now_s) {
  backoff_ = 1;
  last_ask_s_ = now_s;
}

ReplanGate::ReplanGate(const ReplanPolicy& policy) : policy_(policy) { policy_.validate(); }

void ReplanGate::planReady(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return;
  latencies_.push_back(seconds);
  if (latencies_.size() > 8) latencies_.pop_front();
}

double ReplanGate::expectedPlanningTime() const {
  // The second longest of the recent ones once there are two: one slow plan (a first request that waited for the
  // planner's world: 3.3 s on gart_terrain_3d) made every block of the next eight stop the vehicle, a block 2-4 s
  // ahead being "too close" for a plan expected to take 4.1 s. A plan later than predicted is still flown: the
  // switch starts its reference at the vehicle.
  std::vector<double> recent(latencies_.begin(), latencies_.end());
  std::sort(recent.begin(), recent.end(), std::greater<>());
  const double typical = recent.empty() ? 0.0 : recent[std::min<std::size_t>(1, recent.size() - 1)];
  return std::max(policy_.planning_time_s, 1.25 * typical);
}

ReplanVerdict ReplanGate::check(const ReplanDecision& decision, const Trajectory& trajectory, double reference_time) {
  ReplanVerdict out;
  if (!decision.needed) {
    blocked_checks_ = 0;
    return out;
  }
  if (decision.reason == ReplanReason::Deviation) {
    blocked_checks_ = 0;
    out.action = ReplanAction::StopAndReplan;
    out.reason = std::string(toString(decision.reason)) + ": " + decision.message;
    return out;
  }
  ++blocked_checks_;
  const bool deep = decision.penetration > policy_.block_margin;
  const double lead = expectedPlanningTime();
  const bool near = !(decision.time_ahead > lead + policy_.stop_margin_s);  // a stop, not a plan ahead, answers it
  const int needed = near ? std::min(policy_.near_confirm_checks, policy_.confirm_checks) : policy_.confirm_checks;
  if (blocked_checks_ < needed && !deep) return out;
  char why[160];
  std::snprintf(why, sizeof why, " (%s; %.2f s ahead, overlap %.2f m)",
                deep ? "overlap beyond the margin" : (std::to_string(blocked_checks_) + " consecutive checks").c_str(),
                decision.time_ahead, decision.penetration);
  out.reason = std::string(toString(decision.reason)) + ": " + decision.message + why;
  blocked_checks_ = 0;
  if (!near && reference_time + lead < trajectory.duration()) {
    out.action = ReplanAction::ReplanAhead;
    out.start = trajectory.at(reference_time + lead);
  } else {
    out.action = ReplanAction::StopAndReplan;
  }
  return out;
}

namespace {

// Metres free along `direction` from `position` (up to `look`), counted from where the robot there is first
// free within `reach`; 0 when it is not.
double freeAlong(const planner::CollisionWorld& world, const Vec3& position, const Vec3& direction, double look, double reach) {
  const double step = std::max(0.02, std::min(0.1, world.checkResolution()));
  double travelled = 0.0;
  while (!world.isFree(position + travelled * direction)) {
    travelled += step;
    if (travelled > reach) return 0.0;
  }
  while (travelled < look && world.isFree(position + (travelled + step) * direction)) travelled += step;
  return travelled;
}

}  // namespace

double restStartRoom(double robot_radius, std::int64_t failed_plans) {
  const double base = std::max(1.0, 4.0 * (std::isfinite(robot_radius) ? std::max(robot_radius, 0.0) : 0.0));
  return base * static_cast<double>(std::int64_t(1) << std::clamp<std::int64_t>(failed_plans, 0, 3));
}

double restStartHeading(const planner::CollisionWorld& world, const Vec3& position, double heading, double min_free, double reach) {
  const double escape = std::isfinite(reach) ? std::max(reach, world.robotRadius()) : world.robotRadius();
  // In 3-D a vehicle at rest may climb as it sets off (the planner's edges climb at any slope, the smoother flies them
  // within vz_max): a heading is free when it is level, climbing at 15, 30 or 45 degrees, or descending at 15.
  static constexpr double kSlopes[] = {0.0, 0.2679491924311228, 0.5773502691896257, 1.0, -0.2679491924311228};
  const std::size_t slopes = world.dimensions() == 3 ? std::size(kSlopes) : 1;
  const auto freeToward = [&](double angle) {
    double most = 0.0;
    for (std::size_t i = 0; i < slopes && most < min_free; ++i)
      most = std::max(most, freeAlong(world, position, Vec3(std::cos(angle), std::sin(angle), kSlopes[i]).normalized(), min_free, escape));
    return most;
  };
  if (freeToward(heading) >= min_free) return heading;
  constexpr int kDirections = 16;
  double best = heading, best_free = 0.0;
  // The least turn first: +k and -k steps from the heading, k = 1 .. 8.
  for (int k = 1; k <= kDirections / 2; ++k) {
    for (const int sign : {1, -1}) {
      const double angle = wrapAngle(heading + sign * k * (2.0 * std::numbers::pi / kDirections));
      const double free = freeToward(angle);
      if (free >= min_free) return angle;
      if (free > best_free) best = angle, best_free = free;
      if (k == kDirections / 2) break;  // +8 and -8 steps are the same direction
    }
  }
  return best;
}

void StallPolicy::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("stall policy: ") + what);
  };
  require(std::isfinite(stall_s) && stall_s >= 0, "stall_s must be a finite number of seconds >= 0");
  require(std::isfinite(radius_m) && radius_m > 0, "radius_m must be a finite number of metres > 0");
  require(std::isfinite(turn_rad) && turn_rad > 0, "turn_rad must be a finite angle > 0");
}

StallWatch::StallWatch(const StallPolicy& policy) : policy_(policy) { policy_.validate(); }

bool StallWatch::update(double now_s, const Vec3& position, double heading, bool meant_to_fly) {
  const bool moved = since_s_ && ((position - anchor_).norm() >= policy_.radius_m ||
                                  std::abs(wrapAngle(heading - anchor_heading_)) >= policy_.turn_rad);
  if (!meant_to_fly || policy_.stall_s <= 0 || !position.allFinite() || !std::isfinite(heading) || !since_s_ || moved) {
    since_s_.reset();
    if (meant_to_fly && policy_.stall_s > 0 && position.allFinite() && std::isfinite(heading)) {
      since_s_ = now_s;
      anchor_ = position;
      anchor_heading_ = heading;
    }
    return false;
  }
  if (now_s - *since_s_ < policy_.stall_s) return false;
  since_s_ = now_s;  // afresh: a stop and a plan from rest follow, and a stall after them is a new one
  return true;
}

}  // namespace ddsnav::tracker
