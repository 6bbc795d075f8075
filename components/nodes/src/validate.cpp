#include "ddsnav/nodes/validate.hpp"

#include <ddsnav/bus/printable.hpp>
#include <ddsnav/planner/collision_world.hpp>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <utility>

namespace ddsnav::nodes {

namespace {

bool finite(const msg::Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

// Far beyond any world ddsnav plans in, and small enough that centre +- semi-axis and the collision grids'
// cell arithmetic stay finite and inside int (a finite 1e300 overflowed both; found by tests/fuzz, target cdr).
constexpr double kMaxObstacleExtent = 1e6;  // m

bool bounded(const msg::Vec3& v) {
  return std::abs(v.x()) <= kMaxObstacleExtent && std::abs(v.y()) <= kMaxObstacleExtent && std::abs(v.z()) <= kMaxObstacleExtent;
}

std::string checkFrame(const msg::Header& header, const std::string& frame) {
  if (!frame.empty() && header.frame_id() != frame) return fmt::format("frame '{}', expected '{}'", bus::printable(header.frame_id()), frame);
  return {};
}

std::string checkObstacle(const msg::ObstacleEllipsoid& o, bool planar) {
  if (!finite(o.centre())) return fmt::format("non-finite centre ({}, {}, {})", o.centre().x(), o.centre().y(), o.centre().z());
  const auto& s = o.semi_axes();
  if (!finite(s)) return fmt::format("non-finite semi-axes ({}, {}, {})", s.x(), s.y(), s.z());
  if (!bounded(o.centre()) || !bounded(s))
    return fmt::format("centre ({}, {}, {}) or semi-axes ({}, {}, {}) beyond {} m", o.centre().x(), o.centre().y(),
                       o.centre().z(), s.x(), s.y(), s.z(), kMaxObstacleExtent);
  const double axes[3] = {s.x(), s.y(), s.z()};
  const char* names = "xyz";
  for (int i = 0; i < (planar ? 2 : 3); ++i)
    if (!(axes[i] > 0.0)) return fmt::format("semi-axis {} is {}, expected > 0", names[i], axes[i]);
  if (planar && axes[2] < 0.0) return fmt::format("semi-axis z is {}, expected >= 0", axes[2]);
  const auto& q = o.orientation();
  if (!std::isfinite(q.x()) || !std::isfinite(q.y()) || !std::isfinite(q.z()) || !std::isfinite(q.w()))
    return fmt::format("non-finite orientation quaternion ({}, {}, {}, {})", q.w(), q.x(), q.y(), q.z());
  // A zero quaternion is no rotation at all; normalising it would make NaN axes.
  if (!(std::sqrt(q.w() * q.w() + q.x() * q.x() + q.y() * q.y() + q.z() * q.z()) > 1e-9))
    return "orientation quaternion has zero norm";
  for (const double c : o.covariance())
    if (!std::isfinite(c)) return "non-finite covariance";
  return {};
}

}  // namespace

std::string checkObstacleArray(const msg::ObstacleArray& array, const std::string& frame) {
  if (auto error = checkFrame(array.header(), frame); !error.empty()) return error;
  const auto& obstacles = array.obstacles();
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    if (auto error = checkObstacle(obstacles[k], array.planar()); !error.empty())
      return fmt::format("obstacle {} (id {}): {}", k, obstacles[k].id(), error);
  }
  return {};
}

std::string checkOccupancyMap(const msg::OccupancyMap& map, const std::string& frame, const planner::Scenario& scenario) {
  return buildOccupancyMap(map, frame, scenario, planner::OctoMapWorldOptions{}).error;
}

CheckedMap buildOccupancyMap(const msg::OccupancyMap& map, const std::string& frame, const planner::Scenario& scenario,
                             const planner::OctoMapWorldOptions& options) {
  CheckedMap out;
  if (out.error = checkFrame(map.header(), frame); !out.error.empty()) return out;
  if (!(map.resolution() > 0.0) || !std::isfinite(map.resolution())) {
    out.error = fmt::format("resolution is {}, expected a positive finite number of metres", map.resolution());
    return out;
  }
  // The octree bytes are only understood by parsing them: build the world the planner would build.
  try {
    out.world = planner::makeOctoMapWorld(scenario.dimensions, scenario.bounds_min, scenario.bounds_max, scenario.robot_radius,
                                          map.octree(), options);
  } catch (const std::exception& e) {
    out.error = e.what();
  }
  return out;
}

std::string checkVehicleState(const msg::VehicleState& state, const std::string& frame) {
  if (auto error = checkFrame(state.header(), frame); !error.empty()) return error;
  const auto& p = state.position();
  const auto& v = state.velocity();
  const std::pair<const char*, double> fields[] = {{"position.x", p.x()}, {"position.y", p.y()}, {"position.z", p.z()},
                                                   {"heading", state.heading()}, {"velocity.x", v.x()}, {"velocity.y", v.y()},
                                                   {"velocity.z", v.z()}, {"yaw_rate", state.yaw_rate()}};
  for (const auto& [name, value] : fields)
    if (!std::isfinite(value)) return fmt::format("{} is {}", name, value);
  return {};
}

std::string checkPath(const msg::Path& path) {
  const auto& states = path.states();
  if (path.solved() && states.empty()) return "solved, but it has no states";
  for (std::size_t k = 0; k < states.size(); ++k) {
    const auto& s = states[k];
    const std::pair<const char*, double> fields[] = {{"x", s.x()}, {"y", s.y()}, {"z", s.z()}, {"heading", s.heading()}};
    for (const auto& [name, value] : fields)
      if (!std::isfinite(value)) return fmt::format("state {}: {} is {}", k, name, value);
  }
  return {};
}

std::string checkTrajectory(const msg::Trajectory& trajectory) {
  const auto& samples = trajectory.samples();
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const auto& s = samples[k];
    const auto& p = s.position();
    const auto& v = s.velocity();
    const std::pair<const char*, double> fields[] = {{"position.x", p.x()}, {"position.y", p.y()}, {"position.z", p.z()},
                                                     {"heading", s.heading()}, {"velocity.x", v.x()}, {"velocity.y", v.y()},
                                                     {"velocity.z", v.z()}, {"yaw_rate", s.yaw_rate()}};
    for (const auto& [name, value] : fields)
      if (!std::isfinite(value)) return fmt::format("sample {}: {} is {}", k, name, value);
  }
  return {};
}

std::string checkTrackingStatus(const msg::TrackingStatus& status) {
  const std::pair<const char*, double> fields[] = {{"cross_track_error", status.cross_track_error()},
                                                   {"along_track_error", status.along_track_error()},
                                                   {"mean_cross_track_error", status.mean_cross_track_error()},
                                                   {"max_cross_track_error", status.max_cross_track_error()},
                                                   {"progress", status.progress()}};
  for (const auto& [name, value] : fields)
    if (!std::isfinite(value)) return fmt::format("{} is {}", name, value);
  if (!(status.progress() >= 0.0 && status.progress() <= 1.0)) return fmt::format("progress is {}, expected [0, 1]", status.progress());
  return {};
}

std::string checkPlanRequest(const msg::PlanRequest& request, const planner::Scenario& scenario, const std::string& frame) {
  if (auto error = checkFrame(request.header(), frame); !error.empty()) return error;
  const bool planar = scenario.dimensions == 2;
  // In a 2-D world z is no coordinate: the scenario's z bounds are [0, 0], so only z = 0 passes.
  auto checkState = [&](const char* name, const msg::PathState& s) -> std::string {
    const double values[3] = {s.x(), s.y(), s.z()};
    const char* axes = "xyz";
    for (int i = 0; i < 3; ++i) {
      const double lo = scenario.bounds_min[i], hi = scenario.bounds_max[i];
      if (!(values[i] >= lo && values[i] <= hi))  // also refuses NaN
        return fmt::format("{}.{} = {:.9g} is outside the planning bounds [{:.9g}, {:.9g}]{}", name, axes[i], values[i], lo, hi,
                           planar && i == 2 ? " (a 2-D world)" : "");
    }
    if (!std::isfinite(s.heading())) return fmt::format("{}.heading is {}", name, s.heading());
    return {};
  };
  if (auto error = checkState("start", request.start()); !error.empty()) return error;
  if (auto error = checkState("goal", request.goal()); !error.empty()) return error;
  const double diagonal = (scenario.bounds_max - scenario.bounds_min).norm();
  if (!(request.goal_radius() > 0 && request.goal_radius() <= diagonal))
    return fmt::format("goal_radius = {:.9g} m, expected (0, {:.6g}] (the diagonal of the planning bounds)", request.goal_radius(), diagonal);
  if (!(request.time_budget_s() > 0) || !std::isfinite(request.time_budget_s()))
    return fmt::format("time_budget_s = {} s, expected a positive finite number of seconds", request.time_budget_s());
  if (!(request.improve_for_s() >= 0) || !std::isfinite(request.improve_for_s()))
    return fmt::format("improve_for_s = {} s, expected a finite number of seconds >= 0", request.improve_for_s());
  return {};
}

DroppedSamples::DroppedSamples(std::string topic, std::string kept) : topic_(std::move(topic)), kept_(std::move(kept)) {}

void DroppedSamples::drop(const std::string& what) {
  std::lock_guard lock(mutex_);
  ++count_;
  const auto now = std::chrono::steady_clock::now();
  if (count_ > 1 && now - last_warning_ < std::chrono::seconds(1)) return;
  last_warning_ = now;
  spdlog::warn("{}: dropping a sample: {}; {} ({} dropped so far)", topic_, what, kept_, count_);
}

std::size_t DroppedSamples::count() const {
  std::lock_guard lock(mutex_);
  return count_;
}

bool isPlanarCloud(const std::vector<Eigen::Vector3f>& points) {
  for (const auto& p : points)
    if (p.allFinite() && p.z() != 0.0f) return false;
  return true;
}

bool asksForAShorterRoute(const msg::PlanRequest& request) { return request.reason().rfind("shorter_route", 0) == 0; }

}  // namespace ddsnav::nodes
