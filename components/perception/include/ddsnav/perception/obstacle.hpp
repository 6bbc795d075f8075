#pragma once
// An obstacle as perception reports it: the ellipse (2-D) or ellipsoid (3-D) that holds the
// obstacle with probability p under a Gaussian model of its sensed points.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <span>

namespace ddsnav::perception {

struct ObstacleEllipsoid {
  std::uint64_t id = 0;          // stable id from the tracker; 0 for a raw detection
  int dimensions = 3;            // 2: ellipse in the z = 0 plane, 3: ellipsoid
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d semi_axes = Eigen::Vector3d::Zero();  // largest first; z = 0 for an ellipse
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();   // columns: unit axis directions, det = +1
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // same rotation as `axes`
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // obstacle spread incl. sensor noise
  double probability = 0.99;     // p: the ellipsoid holds the obstacle with this probability
  std::size_t point_count = 0;   // points that support the estimate

  // Mahalanobis distance^2 of p from the centre under `covariance` (restricted to x, y in 2-D).
  double mahalanobis2(const Eigen::Vector3d& p) const;
  // True when p lies inside the ellipse / ellipsoid (in 2-D, z is ignored).
  bool contains(const Eigen::Vector3d& p) const;
};

struct EllipsoidFitParams {
  double probability = 0.99;        // p
  double range_noise_sigma = 0.02;  // m, sensor range noise (1 sigma) along each beam
  double voxel_size = 0.0;          // m; adds the uniform-in-voxel variance leaf^2 / 12 per axis
  bool enclose_points = true;       // scale C up (never down) until every cluster point is inside
};

// Fits the probability-p ellipsoid to a cluster:
//   mean m = (1/n) sum x_i
//   C = (1/n) sum (x_i - m)(x_i - m)^T             spread of the sensed surface
//     + (sigma_r^2 / n) sum u_i u_i^T               range noise along each bearing u_i = (x_i - o)/|x_i - o|
//     + (leaf^2 / 12) I                             position quantisation of a voxel centroid
//   semi-axis_k = sqrt(chi2_quantile(p, d) * lambda_k), axis_k = eigenvector_k of C.
// With enclose_points, C is then multiplied by s = max(1, max_i d2_i / chi2_quantile(p, d)), d2_i the
// Mahalanobis distance^2 of point i moved away from the centre by its position uncertainty
// (3 sigma_r + half a voxel diagonal): a sensed surface that is far from Gaussian (an L of two box
// faces, a partly seen arc) keeps its thin Gaussian ellipse only if that ellipse still holds every
// sensed point — the planner must never be told a seen obstacle point is free.
// `dimensions` 2 uses only x, y (an ellipse in the z = 0 plane). `indices` selects points
// (all when empty).
ObstacleEllipsoid fitEllipsoid(std::span<const Eigen::Vector3f> points, std::span<const int> indices,
                               const Eigen::Vector3d& sensor_origin, int dimensions,
                               const EllipsoidFitParams& params);

// Recomputes semi_axes, axes and orientation of `e` from its covariance and probability.
void updateShapeFromCovariance(ObstacleEllipsoid& e);

}  // namespace ddsnav::perception
