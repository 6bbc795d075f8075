#include "ddsnav/sim/ray_primitives.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::sim {
namespace {

// Rotates a vector by -yaw about z (given cos, sin of yaw): world frame -> primitive frame.
Eigen::Vector3d unrotate(const Eigen::Vector3d& v, double c, double s) {
  return {c * v.x() + s * v.y(), -s * v.x() + c * v.y(), v.z()};
}

// Smallest non-negative root of a t^2 + 2 b t + c = 0 that enters the solid (c < 0 means the
// origin is inside, so t = 0).
double enterQuadratic(double a, double b, double c) {
  if (a <= 0.0) return kNoHit;
  const double disc = b * b - a * c;
  if (disc < 0.0) return kNoHit;
  const double root = std::sqrt(disc);
  const double t_far = (-b + root) / a;
  if (t_far < 0.0) return kNoHit;
  if (c <= 0.0) return 0.0;
  const double t_near = (-b - root) / a;
  return std::max(t_near, 0.0);
}

constexpr double kHillCutoffHeight = 1e-3;  // metres

double hillRadius(double height, double sigma) {
  if (height <= kHillCutoffHeight) return 0.0;
  return sigma * std::sqrt(2.0 * std::log(height / kHillCutoffHeight));
}

}  // namespace

double intersectBox(const Ray& ray, const Eigen::Vector3d& center, const Eigen::Vector3d& size,
                    double yaw, bool planar) {
  return intersectBox(ray, center, size, std::cos(yaw), std::sin(yaw), planar);
}

double intersectBox(const Ray& ray, const Eigen::Vector3d& center, const Eigen::Vector3d& size,
                    double cos_yaw, double sin_yaw, bool planar) {
  const Eigen::Vector3d o = unrotate(ray.origin - center, cos_yaw, sin_yaw);
  const Eigen::Vector3d d = unrotate(ray.direction, cos_yaw, sin_yaw);
  double t_near = -kNoHit, t_far = kNoHit;
  const int axes = planar ? 2 : 3;
  for (int k = 0; k < axes; ++k) {
    const double half = 0.5 * size[k];
    if (std::abs(d[k]) < 1e-15) {
      if (std::abs(o[k]) > half) return kNoHit;  // parallel to this slab and outside it
      continue;
    }
    double t1 = (-half - o[k]) / d[k];
    double t2 = (half - o[k]) / d[k];
    if (t1 > t2) std::swap(t1, t2);
    t_near = std::max(t_near, t1);
    t_far = std::min(t_far, t2);
    if (t_near > t_far) return kNoHit;
  }
  if (t_far < 0.0) return kNoHit;
  return std::max(t_near, 0.0);
}

double intersectSphere(const Ray& ray, const Eigen::Vector3d& center, double radius, bool planar) {
  Eigen::Vector3d oc = ray.origin - center;
  Eigen::Vector3d d = ray.direction;
  if (planar) {
    oc.z() = 0.0;
    d.z() = 0.0;
  }
  return enterQuadratic(d.squaredNorm(), oc.dot(d), oc.squaredNorm() - radius * radius);
}

double intersectEllipsoid(const Ray& ray, const Eigen::Vector3d& center,
                          const Eigen::Vector3d& semi_axes, double yaw, bool planar) {
  return intersectEllipsoid(ray, center, semi_axes, std::cos(yaw), std::sin(yaw), planar);
}

double intersectEllipsoid(const Ray& ray, const Eigen::Vector3d& center, const Eigen::Vector3d& semi_axes,
                          double cos_yaw, double sin_yaw, bool planar) {
  Eigen::Vector3d o = unrotate(ray.origin - center, cos_yaw, sin_yaw);
  Eigen::Vector3d d = unrotate(ray.direction, cos_yaw, sin_yaw);
  const int axes = planar ? 2 : 3;
  for (int k = 0; k < 3; ++k) {
    if (k >= axes) {
      o[k] = 0.0;
      d[k] = 0.0;
      continue;
    }
    if (semi_axes[k] <= 0.0) return kNoHit;  // degenerate: no volume
    o[k] /= semi_axes[k];
    d[k] /= semi_axes[k];
  }
  return enterQuadratic(d.squaredNorm(), o.dot(d), o.squaredNorm() - 1.0);
}

double intersectHill(const Ray& ray, const Eigen::Vector3d& center, double height, double sigma,
                     double t_max, double min_step, double tolerance) {
  if (height <= 0.0 || sigma <= 0.0) return kNoHit;
  const Eigen::Vector3d& o = ray.origin;
  const Eigen::Vector3d& d = ray.direction;
  const double inv_two_sigma2 = 1.0 / (2.0 * sigma * sigma);
  auto gap = [&](double t) {  // height of the ray above the hill surface at t
    const double x = o.x() + t * d.x() - center.x();
    const double y = o.y() + t * d.y() - center.y();
    return o.z() + t * d.z() - height * std::exp(-(x * x + y * y) * inv_two_sigma2);
  };

  // Clip the march to the cut-off cylinder of the hill, z in [-inf, height].
  const double radius = hillRadius(height, sigma);
  double t0 = 0.0, t1 = t_max;
  {
    const Eigen::Vector3d box_center(center.x(), center.y(), 0.5 * height - 1e6);
    const Eigen::Vector3d box_size(2 * radius, 2 * radius, height + 2e6);
    const double t_enter = intersectBox(ray, box_center, box_size, 1.0, 0.0, false);
    if (t_enter == kNoHit || t_enter > t_max) return kNoHit;
    t0 = t_enter;
    // Leaving the cylinder's bounding box: march at most to the far side.
    const double dxy = std::hypot(d.x(), d.y());
    if (dxy > 1e-12) {
      const double ox = o.x() - center.x(), oy = o.y() - center.y();
      const double b = (ox * d.x() + oy * d.y()) / dxy;
      const double c = ox * ox + oy * oy - 2.0 * radius * radius;  // circumscribed circle of the box
      const double disc = b * b - c;
      if (disc > 0.0) t1 = std::min(t1, (-b + std::sqrt(disc)) / dxy);
    }
  }
  if (d.z() > 0.0) t1 = std::min(t1, (height - o.z()) / d.z());  // climbing above the peak: no hit
  if (t0 > t1) return kNoHit;
  // Exact rejection before the march (most beams of a 3-D lidar pass a hill well above its flank): on
  // [t0, t1] the ray is nowhere lower than at one of the ends, and the hill nowhere higher than at the
  // ray's closest horizontal approach to its centre (the height falls with the distance).
  {
    const double ox = o.x() - center.x(), oy = o.y() - center.y();
    const double dxy2 = d.x() * d.x() + d.y() * d.y();
    const double tc = dxy2 > 1e-24 ? std::clamp(-(ox * d.x() + oy * d.y()) / dxy2, t0, t1) : t0;
    const double cx = ox + tc * d.x(), cy = oy + tc * d.y();
    const double highest = height * std::exp(-(cx * cx + cy * cy) * inv_two_sigma2);
    if (std::min(o.z() + t0 * d.z(), o.z() + t1 * d.z()) > highest) return kNoHit;
  }

  double g0 = gap(t0);
  if (g0 <= 0.0) return t0;  // starts inside (or on) the hill
  const double lipschitz =
      std::abs(d.z()) + std::hypot(d.x(), d.y()) * height / sigma * std::exp(-0.5) + 1e-12;
  double t = t0;
  for (int step = 0; step < 100000 && t < t1; ++step) {
    const double next = std::min(t1, t + std::max(g0 / lipschitz, min_step));
    const double g1 = gap(next);
    if (g1 <= 0.0) {
      double lo = t, hi = next;  // gap(lo) > 0 >= gap(hi)
      while (hi - lo > tolerance) {
        const double mid = 0.5 * (lo + hi);
        (gap(mid) > 0.0 ? lo : hi) = mid;
      }
      return hi;
    }
    t = next;
    g0 = g1;
  }
  return kNoHit;
}

double intersect(const Ray& ray, const planner::Obstacle& obstacle, bool planar, double t_max) {
  return intersect(ray, obstacle, std::cos(obstacle.yaw), std::sin(obstacle.yaw), planar, t_max);
}

double intersect(const Ray& ray, const planner::Obstacle& obstacle, double cos_yaw, double sin_yaw, bool planar,
                 double t_max) {
  using planner::ObstacleType;
  switch (obstacle.type) {
    case ObstacleType::Box:
      return intersectBox(ray, obstacle.center, obstacle.size, cos_yaw, sin_yaw, planar);
    case ObstacleType::Sphere:
      return intersectSphere(ray, obstacle.center, obstacle.radius, planar);
    case ObstacleType::Ellipsoid:
      return intersectEllipsoid(ray, obstacle.center, obstacle.semi_axes, cos_yaw, sin_yaw, planar);
    case ObstacleType::Hill:
      if (planar) return kNoHit;
      return intersectHill(ray, obstacle.center, obstacle.height, obstacle.sigma, t_max);
  }
  return kNoHit;
}

void boundingSphere(const planner::Obstacle& obstacle, bool planar, Eigen::Vector3d& center,
                    double& radius) {
  using planner::ObstacleType;
  center = obstacle.center;
  switch (obstacle.type) {
    case ObstacleType::Box: {
      Eigen::Vector3d half = 0.5 * obstacle.size;
      if (planar) half.z() = 0.0;
      radius = half.norm();
      break;
    }
    case ObstacleType::Sphere:
      radius = obstacle.radius;
      break;
    case ObstacleType::Ellipsoid: {
      Eigen::Vector3d a = obstacle.semi_axes;
      if (planar) a.z() = 0.0;
      radius = a.maxCoeff();
      break;
    }
    case ObstacleType::Hill: {
      const double r = hillRadius(obstacle.height, obstacle.sigma);
      center.z() = 0.5 * obstacle.height;
      // Bounds the cut-off cylinder between z = 0 and the peak; the part below z = 0 is
      // underground (behind the floor) and only reachable by rays that first cross z = 0.
      radius = std::hypot(r, 0.5 * obstacle.height);
      break;
    }
  }
  if (planar) center.z() = 0.0;
}

double exitBounds(const Ray& ray, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                  bool sides, bool floor, bool ceiling, bool planar) {
  double t = kNoHit;
  const Eigen::Vector3d& o = ray.origin;
  const Eigen::Vector3d& d = ray.direction;
  if (sides) {
    for (int k = 0; k < 2; ++k) {
      if (d[k] > 1e-15) t = std::min(t, (hi[k] - o[k]) / d[k]);
      if (d[k] < -1e-15) t = std::min(t, (lo[k] - o[k]) / d[k]);
    }
  }
  if (!planar) {
    if (ceiling && d.z() > 1e-15) t = std::min(t, (hi.z() - o.z()) / d.z());
    if (floor && d.z() < -1e-15) t = std::min(t, (lo.z() - o.z()) / d.z());
  }
  return t < 0.0 ? 0.0 : t;
}

}  // namespace ddsnav::sim
