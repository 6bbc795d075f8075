// makeScenarioWorld: the scenario's obstacle primitives, exactly, as a ShapeWorld.
#include "shape_world.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace ddsnav::planner {

namespace {

Eigen::Matrix3d yawRotation(double yaw) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r(0, 0) = std::cos(yaw), r(0, 1) = -std::sin(yaw);
  r(1, 0) = std::sin(yaw), r(1, 1) = std::cos(yaw);
  return r;
}

detail::Shape toShape(const Obstacle& o, int id, int dims) {
  detail::Shape s;
  s.type = o.type;
  s.id = id;
  s.center = o.center;
  if (dims == 2) s.center.z() = 0.0;
  switch (o.type) {
    case ObstacleType::Box: {
      s.axes = yawRotation(o.yaw);
      s.half = 0.5 * o.size;
      if (dims == 2) s.half.z() = 0.0;
      // Bounds of the rotated box: |R| * half.
      const Vec3 ext = s.axes.cwiseAbs() * s.half;
      s.lo = s.center - ext, s.hi = s.center + ext;
      break;
    }
    case ObstacleType::Sphere:
      s.radius = o.radius;
      s.lo = s.center - Vec3::Constant(o.radius), s.hi = s.center + Vec3::Constant(o.radius);
      break;
    case ObstacleType::Ellipsoid: {
      s.axes = yawRotation(o.yaw);
      s.half = o.semi_axes;
      if (dims == 2) s.half.z() = 0.0;
      // Bounds of a rotated ellipsoid: sqrt(sum_j (R_ij e_j)^2) along world axis i.
      Vec3 ext;
      for (int i = 0; i < 3; ++i) ext[i] = (s.axes.row(i).transpose().cwiseProduct(s.half)).norm();
      s.lo = s.center - ext, s.hi = s.center + ext;
      break;
    }
    case ObstacleType::Hill: {
      s.height = o.height;
      s.sigma = o.sigma;
      s.center.z() = 0.0;
      // Beyond this horizontal distance the hill is lower than kHillCutoff (the ground takes over).
      const double reach =
          o.height > detail::kHillCutoff ? o.sigma * std::sqrt(2.0 * std::log(o.height / detail::kHillCutoff)) : 0.0;
      s.lo = Vec3(s.center.x() - reach, s.center.y() - reach, -std::numeric_limits<double>::infinity());
      s.hi = Vec3(s.center.x() + reach, s.center.y() + reach, o.height);
      break;
    }
  }
  if (dims == 2) s.lo.z() = s.hi.z() = 0.0;
  return s;
}

}  // namespace

std::unique_ptr<CollisionWorld> makeScenarioWorld(const Scenario& scenario) {
  if (scenario.dimensions != 2 && scenario.dimensions != 3) {
    throw std::invalid_argument("makeScenarioWorld: dimensions must be 2 or 3");
  }
  std::vector<detail::Shape> shapes;
  shapes.reserve(scenario.obstacles.size());
  for (std::size_t i = 0; i < scenario.obstacles.size(); ++i) {
    shapes.push_back(toShape(scenario.obstacles[i], static_cast<int>(i), scenario.dimensions));
  }
  return std::make_unique<detail::ShapeWorld>(scenario.dimensions, scenario.bounds_min, scenario.bounds_max,
                                              scenario.robot_radius, std::move(shapes));
}

}  // namespace ddsnav::planner
