// makeEllipsoidWorld: obstacle ellipses/ellipsoids as perception publishes them, exact distances.
#include "shape_world.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>
#include <string>

namespace ddsnav::planner {

std::unique_ptr<CollisionWorld> makeEllipsoidWorld(int dimensions, const Vec3& bounds_min, const Vec3& bounds_max,
                                                   double robot_radius, std::vector<EllipsoidObstacle> obstacles) {
  if (dimensions != 2 && dimensions != 3) throw std::invalid_argument("makeEllipsoidWorld: dimensions must be 2 or 3");
  for (int i = 0; i < dimensions; ++i) {
    if (!std::isfinite(bounds_min[i]) || !std::isfinite(bounds_max[i]) || !(bounds_max[i] > bounds_min[i])) {
      throw std::invalid_argument("makeEllipsoidWorld: bounds must be finite with max > min on every axis");
    }
  }
  if (!std::isfinite(robot_radius) || robot_radius < 0.0) {
    throw std::invalid_argument("makeEllipsoidWorld: robot_radius must be finite and >= 0");
  }
  std::vector<detail::Shape> shapes;
  shapes.reserve(obstacles.size());
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    const EllipsoidObstacle& o = obstacles[k];
    const std::string which = "makeEllipsoidWorld: obstacle " + std::to_string(k) + " (id " + std::to_string(o.id) + ")";
    if (!o.center.allFinite() || !o.semi_axes.allFinite() || !o.axes.allFinite()) {
      throw std::invalid_argument(which + ": non-finite numbers");
    }
    for (int i = 0; i < dimensions; ++i) {
      if (!(o.semi_axes[i] > 0.0)) throw std::invalid_argument(which + ": semi-axes must be positive");
    }
    const int n = dimensions;
    const Eigen::MatrixXd a = o.axes.topLeftCorner(n, n);
    if (!(a.transpose() * a).isIdentity(1e-6)) throw std::invalid_argument(which + ": axes must be orthonormal");
    detail::Shape s;
    s.type = ObstacleType::Ellipsoid;
    s.id = o.id;
    s.center = o.center;
    s.axes = Eigen::Matrix3d::Identity();
    s.axes.topLeftCorner(n, n) = a;
    s.half = o.semi_axes;
    if (n == 2) s.center.z() = 0.0, s.half.z() = 0.0;
    Vec3 ext;
    for (int i = 0; i < 3; ++i) ext[i] = (s.axes.row(i).transpose().cwiseProduct(s.half)).norm();
    s.lo = s.center - ext, s.hi = s.center + ext;
    if (n == 2) s.lo.z() = s.hi.z() = 0.0;
    shapes.push_back(s);
  }
  return std::make_unique<detail::ShapeWorld>(dimensions, bounds_min, bounds_max, robot_radius, std::move(shapes));
}

}  // namespace ddsnav::planner
