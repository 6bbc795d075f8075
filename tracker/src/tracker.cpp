#include "ddsnav/tracker/tracker.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace ddsnav::tracker {

const char* toString(ReplanReason reason) {
  switch (reason) {
    case ReplanReason::None: return "none";
    case ReplanReason::Deviation: return "deviation";
    case ReplanReason::TrajectoryBlocked: return "trajectory_blocked";
  }
  return "unknown";
}

TrajectoryTracker::TrajectoryTracker(Trajectory trajectory, const VehicleLimits& limits, const TrackerConfig& config)
    : trajectory_(std::make_shared<const Trajectory>(std::move(trajectory))), limits_(limits), config_(config) {
  if (trajectory_->samples.size() < 2) throw std::invalid_argument("tracker: trajectory needs at least 2 samples");
  if (!(limits_.v_max > 0) || !(limits_.omega_max > 0) || !std::isfinite(limits_.v_max) || !std::isfinite(limits_.omega_max))
    throw std::invalid_argument("tracker: v_max and omega_max must be positive numbers");
  if (trajectory_->dimensions == 3 && !(limits_.vz_max > 0)) throw std::invalid_argument("tracker: vz_max must be > 0 in 3-D");
  for (double g : {config_.zeta, config_.b, config_.max_natural_frequency, config_.min_gain, config_.max_lead, config_.lookahead_min, config_.goal_tolerance,
                   config_.replan_deviation})
    if (!(g > 0) || !std::isfinite(g)) throw std::invalid_argument("tracker: gains, distances and tolerances must be positive numbers");
  if (!(config_.lookahead_time >= 0) || !(config_.replan_horizon > 0))
    throw std::invalid_argument("tracker: lookahead_time must be >= 0 and replan_horizon > 0");
  if (!(config_.replan_horizon_distance >= 0) || !std::isfinite(config_.replan_horizon_distance))
    throw std::invalid_argument("tracker: replan_horizon_distance must be a finite number of metres >= 0");
  if (!(config_.catch_up_decel >= 0) || !std::isfinite(config_.catch_up_decel))
    throw std::invalid_argument("tracker: catch_up_decel must be a finite number of m/s^2 >= 0 (0: no cap)");
}

TrajectorySample TrajectoryTracker::sampleAtArcLength(double s) const {
  const auto& samples = trajectory_->samples;
  auto it = std::lower_bound(samples.begin(), samples.end(), s,
                             [](const TrajectorySample& a, double v) { return a.arc_length < v; });
  if (it == samples.end()) return samples.back();
  return *it;
}

TrajectoryTracker::Projection TrajectoryTracker::project(const Vec3& position) const {
  const auto& s = trajectory_->samples;
  // Search a window around the previous projection so that a path passing near itself (a hairpin) cannot
  // make the projection jump to the wrong part of it.
  const double s_ref = trajectory_->at(status_.reference_time).arc_length;
  const double s_prev = s[last_segment_].arc_length;
  const double s_hi = std::max(s_prev, s_ref) + 2.0 * config_.max_lead + 1.0;
  std::size_t lo = last_segment_;
  while (lo > 0 && s[lo].arc_length > s_prev - 0.5) --lo;
  Projection best;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t i = lo; i + 1 < s.size(); ++i) {
    if (s[i].arc_length > s_hi) break;
    const Vec3 a = s[i].position, ab = s[i + 1].position - a;
    const double len2 = ab.squaredNorm();
    const double f = len2 > 0 ? std::clamp((position - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const Vec3 p = a + f * ab;
    const double d = (position - p).norm();
    if (d < best_d) {
      best_d = d;
      best.segment = i;
      best.point = p;
      best.arc_length = s[i].arc_length + f * (s[i + 1].arc_length - s[i].arc_length);
      // Left of the path positive: sign of the horizontal cross product tangent x offset.
      const double h = s[i].heading + f * (s[i + 1].heading - s[i].heading);
      const Vec3 off = position - p;
      const double side = std::cos(h) * off.y() - std::sin(h) * off.x();
      best.signed_distance = side < 0 ? -d : d;
    }
  }
  return best;
}

VehicleCommand TrajectoryTracker::feedforwardFeedback(const VehicleState& state, const TrajectorySample& ref) const {
  // Error of the reference seen from the vehicle: e1 ahead, e2 to the left, e3 heading.
  const double c = std::cos(state.heading), s = std::sin(state.heading);
  const Vec3 d = ref.position - state.position;
  const double e1 = c * d.x() + s * d.y();
  const double e2 = -s * d.x() + c * d.y();
  const double e3 = wrapAngle(ref.heading - state.heading);
  const double vr = ref.speed, wr = ref.yaw_rate;
  // Natural frequency of the linearised error dynamics: sqrt(omega_r^2 + b v_r^2) (Kanayama / de Luca-Oriolo
  // scheduling), capped so that fast references do not ask for more turn rate than the vehicle has.
  const double a = std::min(std::sqrt(wr * wr + config_.b * vr * vr), config_.max_natural_frequency);
  const double k_along = std::max(config_.min_gain, 2 * config_.zeta * a);
  const double k_lateral = vr > 1e-6 ? std::max(0.0, (a * a - wr * wr) / vr) : 0.0;
  const double sinc = std::abs(e3) < 1e-6 ? 1.0 : std::sin(e3) / e3;
  VehicleCommand cmd;
  cmd.v = vr * std::cos(e3) + k_along * e1;
  cmd.omega = wr + k_lateral * sinc * e2 + k_along * e3;
  cmd.vz = ref.vz + k_along * d.z();
  return cmd;
}

VehicleCommand TrajectoryTracker::purePursuit(const VehicleState& state, const Projection& proj) const {
  const TrajectorySample here = sampleAtArcLength(proj.arc_length);
  const double lookahead = config_.lookahead_min + config_.lookahead_time * here.speed;
  const TrajectorySample target = sampleAtArcLength(proj.arc_length + lookahead);
  const Vec3 d = target.position - state.position;
  const double dist = std::hypot(d.x(), d.y());
  VehicleCommand cmd;
  cmd.vz = here.vz + 1.0 * d.z();
  if (dist < 1e-6) {
    cmd.omega = 2.0 * wrapAngle(target.heading - state.heading);
    return cmd;
  }
  const double alpha = wrapAngle(std::atan2(d.y(), d.x()) - state.heading);
  if (std::abs(alpha) > std::numbers::pi / 3) {  // facing away: turn in place first
    cmd.omega = std::copysign(limits_.omega_max, alpha);
    return cmd;
  }
  cmd.v = std::max(here.speed, 0.05 * limits_.v_max);
  cmd.omega = 2.0 * cmd.v * std::sin(alpha) / dist;
  return cmd;
}

VehicleCommand TrajectoryTracker::approachGoal(const VehicleState& state) const {
  // The reference has finished but the vehicle is not there yet: drive to the end point.
  const Vec3 d = trajectory_->samples.back().position - state.position;
  const double dist = std::hypot(d.x(), d.y());
  const double bearing = wrapAngle(std::atan2(d.y(), d.x()) - state.heading);
  VehicleCommand cmd;
  cmd.omega = 1.5 * bearing;
  cmd.v = std::abs(bearing) < 0.5 ? std::min(config_.min_gain * dist, 0.2 * limits_.v_max) * std::cos(bearing) : 0.0;
  cmd.vz = config_.min_gain * d.z();
  return cmd;
}

VehicleCommand TrajectoryTracker::update(const VehicleState& state, double dt) {
  if (!(dt > 0) || !std::isfinite(dt)) throw std::invalid_argument("tracker: update dt must be a positive finite number");
  if (!state.position.allFinite() || !std::isfinite(state.heading))
    throw std::invalid_argument("tracker: vehicle state has non-finite values");
  const auto& samples = trajectory_->samples;
  status_.time += dt;
  ++status_.updates;

  // Advance the reference unless it is already too far ahead of the vehicle.
  const Projection before = project(state.position);
  const double next_time = std::min(status_.reference_time + dt, trajectory_->duration());
  if (trajectory_->at(next_time).arc_length - before.arc_length <= config_.max_lead) status_.reference_time = next_time;
  const TrajectorySample ref = trajectory_->at(status_.reference_time);

  const Projection proj = project(state.position);
  last_segment_ = proj.segment;
  status_.cross_track_error = proj.signed_distance;
  status_.along_track_error = proj.arc_length - ref.arc_length;
  status_.heading_error = wrapAngle(state.heading - ref.heading);
  status_.position_error = (state.position - ref.position).norm();
  sum_cross_ += std::abs(status_.cross_track_error);
  sum_position_ += status_.position_error;
  status_.mean_cross_track_error = sum_cross_ / static_cast<double>(status_.updates);
  status_.mean_position_error = sum_position_ / static_cast<double>(status_.updates);
  status_.max_cross_track_error = std::max(status_.max_cross_track_error, std::abs(status_.cross_track_error));
  const double length = trajectory_->length();
  status_.progress = length > 0 ? std::clamp(proj.arc_length / length, 0.0, 1.0) : 1.0;

  const bool reference_done = status_.reference_time >= trajectory_->duration();
  if (!status_.goal_reached && reference_done &&
      (state.position - samples.back().position).norm() <= config_.goal_tolerance)
    status_.goal_reached = true;
  if (status_.goal_reached) {
    status_.progress = 1.0;
    return {};
  }

  VehicleCommand cmd;
  if (reference_done && (state.position - samples.back().position).norm() > config_.goal_tolerance &&
      config_.controller == ControllerType::FeedforwardFeedback && status_.position_error > 2 * config_.goal_tolerance)
    cmd = approachGoal(state);
  else if (config_.controller == ControllerType::FeedforwardFeedback)
    cmd = feedforwardFeedback(state, ref);
  else if (reference_done)
    cmd = approachGoal(state);
  else
    cmd = purePursuit(state, proj);

  if (!reference_done) cmd.v = std::min(cmd.v, brakingCap(proj));
  // Stopping within observed space (limitToObservedSpace).
  observed_cap_ = std::numeric_limits<double>::infinity();
  if (observed_arc_ < std::numeric_limits<double>::infinity()) {
    const double room = observed_arc_ - proj.arc_length;
    observed_cap_ = std::max(observed_crawl_, std::sqrt(2 * observed_decel_ * std::max(0.0, room)));
    cmd.v = std::min(cmd.v, observed_cap_);
  }
  cmd.v = std::clamp(cmd.v, 0.0, limits_.v_max);
  cmd.omega = std::clamp(cmd.omega, -limits_.omega_max, limits_.omega_max);
  cmd.vz = trajectory_->dimensions == 3 ? std::clamp(cmd.vz, -limits_.vz_max, limits_.vz_max) : 0.0;
  return cmd;
}

double TrajectoryTracker::brakingCap(const Projection& proj) const {
  const double a = config_.catch_up_decel;
  if (!(a > 0)) return std::numeric_limits<double>::infinity();
  const auto& samples = trajectory_->samples;
  // From the reference on (a stop it has already made, a turn in place at the start, is behind it: counting those
  // would hold the vehicle there for good) and ahead of the vehicle; samples farther than the stopping distance
  // from v_max cannot lower the cap below v_max.
  const auto from_reference = std::lower_bound(samples.begin(), samples.end(), status_.reference_time,
                                               [](const TrajectorySample& sample, double time) { return sample.time < time; });
  const double reach = limits_.v_max * limits_.v_max / (2 * a);
  double cap = std::numeric_limits<double>::infinity();
  for (auto j = std::max(from_reference, samples.begin() + static_cast<std::ptrdiff_t>(proj.segment) + 1); j < samples.end(); ++j) {
    const double ahead = j->arc_length - proj.arc_length;
    if (ahead > reach) break;
    cap = std::min(cap, std::sqrt(j->speed * j->speed + 2 * a * std::max(0.0, ahead)));
  }
  return cap;
}

void TrajectoryTracker::limitToObservedSpace(double arc, double decel, double crawl_speed) {
  if (std::isnan(arc)) throw std::invalid_argument("tracker: the observed-space bound's arc length is NaN");
  if (!(decel > 0) || !std::isfinite(decel)) throw std::invalid_argument("tracker: the observed-space bound's deceleration must be positive");
  if (!(crawl_speed >= 0) || !std::isfinite(crawl_speed))
    throw std::invalid_argument("tracker: the observed-space bound's crawl speed must be finite and >= 0");
  observed_arc_ = arc;
  observed_decel_ = decel;
  observed_crawl_ = crawl_speed;
}

double TrajectoryTracker::skipToVehicle(const Vec3& position, double within_s) {
  if (!position.allFinite() || !(within_s > 0) || status_.updates > 0) return 0.0;
  const auto& s = trajectory_->samples;
  // The nearest point of the trajectory's first within_s seconds, up to its first stop; a later part passing nearby
  // (a loop back, or the way back after a braking lead-in's turn in place: a vehicle that overshot the stop would skip
  // the turn and swing into whatever it stopped for) is not considered.
  double best_d = std::numeric_limits<double>::infinity();
  double best_time = 0.0;
  std::size_t best_segment = 0;
  for (std::size_t i = 0; i + 1 < s.size() && s[i].time <= within_s; ++i) {
    if (i > 0 && s[i].speed < 1e-6 && std::abs(s[i].vz) < 1e-6) break;
    const Vec3 a = s[i].position, ab = s[i + 1].position - a;
    const double len2 = ab.squaredNorm();
    const double f = len2 > 0 ? std::clamp((position - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double d = (position - (a + f * ab)).norm();
    if (d < best_d - 1e-9) {
      best_d = d;
      best_time = s[i].time + f * (s[i + 1].time - s[i].time);
      best_segment = i;
    }
  }
  if (best_time <= 0.0) return 0.0;
  status_.reference_time = std::min(best_time, trajectory_->duration());
  last_segment_ = best_segment;
  return status_.reference_time;
}

ReplanDecision TrajectoryTracker::checkReplan(const planner::CollisionWorld& world, double min_horizon_s) const {
  ReplanDecision out;
  if (status_.goal_reached) return out;
  if (std::abs(status_.cross_track_error) > config_.replan_deviation) {
    std::ostringstream m;
    m << "cross-track error " << std::abs(status_.cross_track_error) << " m exceeds the replan threshold "
      << config_.replan_deviation << " m";
    out = {true, ReplanReason::Deviation, m.str(), Vec3::Zero()};
    return out;
  }
  const auto& s = trajectory_->samples;
  const double horizon = std::isfinite(min_horizon_s) ? std::max(config_.replan_horizon, min_horizon_s) : config_.replan_horizon;
  const double until = status_.reference_time + horizon;
  const double until_arc = trajectory_->at(status_.reference_time).arc_length + config_.replan_horizon_distance;
  const auto within = [&](const TrajectorySample& sample) { return sample.time <= until || sample.arc_length <= until_arc; };
  for (std::size_t i = last_segment_; i < s.size() && within(s[i]); ++i) {
    if (world.isFree(s[i].position)) continue;
    std::ostringstream m;
    m << "trajectory sample at t=" << s[i].time << " s (" << s[i].position.x() << ", " << s[i].position.y()
      << ", " << s[i].position.z() << ") is no longer collision free";
    out = {true, ReplanReason::TrajectoryBlocked, m.str(), s[i].position};
    out.time_ahead = std::max(0.0, s[i].time - status_.reference_time);
    // The first blocked sample only touches the obstacle (the one before it was free): the overlap that
    // tells a graze from a real block is the deepest along the blocked run that follows.
    for (std::size_t k = i; k < s.size() && within(s[k]) && !world.isFree(s[k].position); ++k) {
      const double clearance = world.clearance(s[k].position);
      if (std::isfinite(clearance)) out.penetration = std::max(out.penetration, -clearance);  // bounds only: 0
    }
    return out;
  }
  return out;
}

}  // namespace ddsnav::tracker
