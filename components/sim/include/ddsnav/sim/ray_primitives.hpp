#pragma once
// Exact ray / primitive intersections for every obstacle type of the scenario format.
//
// Every function returns the ray parameter t >= 0 at which the ray first enters the solid
// (t = 0 when the origin is already inside), or kNoHit. The direction must be a unit vector,
// so t is a distance in metres.
//
// "Planar" means a 2-D scenario: the ray lies in the z = 0 plane and every primitive is its
// 2-D footprint (box -> rectangle, sphere -> circle, ellipsoid -> ellipse); z is ignored.

#include <ddsnav/planner/scenario.hpp>

#include <Eigen/Core>

#include <limits>

namespace ddsnav::sim {

inline constexpr double kNoHit = std::numeric_limits<double>::infinity();

struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit length
};

// Box of full edge lengths `size` centred at `center`, rotated by `yaw` about z. Slab method.
double intersectBox(const Ray& ray, const Eigen::Vector3d& center, const Eigen::Vector3d& size,
                    double yaw, bool planar);

// Sphere (circle when planar). Closed-form quadratic.
double intersectSphere(const Ray& ray, const Eigen::Vector3d& center, double radius, bool planar);

// Ellipsoid (ellipse when planar) with semi-axes along the yaw-rotated frame. The ray is mapped
// into the frame where the ellipsoid is the unit sphere, where the quadratic is exact.
double intersectEllipsoid(const Ray& ray, const Eigen::Vector3d& center,
                          const Eigen::Vector3d& semi_axes, double yaw, bool planar);

// Hill height field: solid where z <= height * exp(-d^2 / (2 sigma^2)), d the horizontal distance
// to `center` (z of the centre is ignored, as in the scenario format). A height field has no
// closed-form ray intersection, so this is a conservative march plus bisection:
//  - g(t) = z(t) - h(x(t), y(t)) is Lipschitz in t with L = |dz| + |dxy| * height/sigma * e^-1/2
//    (the steepest slope of the Gaussian), so stepping by g/L can never jump over a root;
//  - steps are floored at `min_step` (grazing rays would otherwise crawl), and a sign change of g
//    is then refined by bisection to `tolerance`.
// A crossing can only be missed if the ray dips into the hill and leaves it again within one
// min_step, i.e. penetrates less than about L*min_step/2. The hill is cut off where its height
// falls below 1 mm (radius sigma*sqrt(2 ln(height/1e-3))).
double intersectHill(const Ray& ray, const Eigen::Vector3d& center, double height, double sigma,
                     double t_max, double min_step = 0.01, double tolerance = 1e-6);

// Dispatches on the obstacle type. Hills are 3-D only (planar hills return kNoHit).
double intersect(const Ray& ray, const planner::Obstacle& obstacle, bool planar, double t_max);

// The same with cos(yaw), sin(yaw) precomputed (the simulator's inner loop).
double intersect(const Ray& ray, const planner::Obstacle& obstacle, double cos_yaw, double sin_yaw, bool planar,
                 double t_max);
double intersectBox(const Ray& ray, const Eigen::Vector3d& center, const Eigen::Vector3d& size, double cos_yaw,
                    double sin_yaw, bool planar);
double intersectEllipsoid(const Ray& ray, const Eigen::Vector3d& center, const Eigen::Vector3d& semi_axes,
                          double cos_yaw, double sin_yaw, bool planar);

// Axis-aligned bounding sphere of an obstacle (centre, radius), for the angular broad phase.
// For a hill it bounds the cut-off cylinder described above.
void boundingSphere(const planner::Obstacle& obstacle, bool planar, Eigen::Vector3d& center,
                    double& radius);

// Distance at which a ray starting inside the box [lo, hi] leaves it through the faces that are
// enabled (x/y side faces, the z = lo floor, the z = hi ceiling). kNoHit when it leaves through none.
// Planar rays only test the x/y faces.
double exitBounds(const Ray& ray, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                  bool sides, bool floor, bool ceiling, bool planar);

}  // namespace ddsnav::sim
