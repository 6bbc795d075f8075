#include "ddsnav/nodes/validate.hpp"

#include <ddsnav/planner/collision_world.hpp>

#include <spdlog/fmt/fmt.h>

#include <cmath>

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
  if (!frame.empty() && header.frame_id() != frame) return fmt::format("frame '{}', expected '{}'", header.frame_id(), frame);
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
  if (auto error = checkFrame(map.header(), frame); !error.empty()) return error;
  if (!(map.resolution() > 0.0) || !std::isfinite(map.resolution()))
    return fmt::format("resolution is {}, expected a positive finite number of metres", map.resolution());
  // The octree bytes are only understood by parsing them: build the world the planner would build.
  try {
    planner::makeOctoMapWorld(scenario.dimensions, scenario.bounds_min, scenario.bounds_max, scenario.robot_radius, map.octree());
  } catch (const std::exception& e) {
    return e.what();
  }
  return {};
}

bool isPlanarCloud(const std::vector<Eigen::Vector3f>& points) {
  for (const auto& p : points)
    if (p.allFinite() && p.z() != 0.0f) return false;
  return true;
}

}  // namespace ddsnav::nodes
