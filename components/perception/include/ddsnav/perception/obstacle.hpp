#pragma once
// An obstacle as perception reports it: the ellipse (2-D) or ellipsoid (3-D) that holds the
// obstacle with probability p under a Gaussian model of its sensed points.

#include <ddsnav/perception/euclidean_clusters.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace ddsnav::perception {

// One piece of evidence for an obstacle: a voxel centroid (world frame) and the unit direction of
// the beam that saw it (sensor -> point; zero when unknown), which carries the range-noise term.
struct SupportPoint {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();
  Eigen::Vector3f bearing = Eigen::Vector3f::Zero();
};

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
  // The voxel centroids the estimate was fitted to (filled by the detector and the tracker; the
  // tracker associates on these, never on overlapping ellipses). Empty when unknown.
  std::vector<SupportPoint> support;

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
  // 2-D, with enclose_points: the major axis ends one enclosing margin beyond the farthest point along it (a piece
  // of wall ends about where its points end, not 0.38 x its length beyond); never lengthens
  bool shorten_to_points = true;
};

// Fits the probability-p ellipsoid to a cluster:
//   mean m = (1/n) sum x_i
//   C = (1/n) sum (x_i - m)(x_i - m)^T             spread of the sensed surface
//     + (sigma_r^2 / n) sum u_i u_i^T               range noise along each bearing u_i = (x_i - o)/|x_i - o|
//     + (leaf^2 / 12) I                             position quantisation of a voxel centroid
//   semi-axis_k = sqrt(chi2_quantile(p, d) * lambda_k), axis_k = eigenvector_k of C.
// With enclose_points, C is then grown (never shrunk) until every cluster point, moved away from the
// centre by its position uncertainty (3 sigma_r + half a voxel diagonal), has Mahalanobis distance^2
// <= chi2_quantile(p, d): a point that sticks out mostly along one principal axis grows that axis's
// variance only (up to 8 such steps), anything left scales C uniformly. A sensed surface that is
// far from Gaussian (an L of two box faces, a partly seen arc) keeps its Gaussian ellipse only if
// that ellipse holds every sensed point — the planner must never be told a seen obstacle point is
// free — and a thin piece with one corner voxel gets thicker, not metres longer. In 2-D, with shorten_to_points (the
// default), the major axis is then shortened to end one enclosing margin beyond the farthest pushed-out point along
// it, every point still inside: along a piece of wall the points are spread evenly, not as a Gaussian, and the
// p-bound beyond its last point (0.56 m past a 1.5 m piece) is free space or the next piece's (docs/perception.md).
// `dimensions` 2 uses only x, y (an ellipse in the z = 0 plane). `indices` selects points
// (all when empty).
ObstacleEllipsoid fitEllipsoid(std::span<const Eigen::Vector3f> points, std::span<const int> indices,
                               const Eigen::Vector3d& sensor_origin, int dimensions,
                               const EllipsoidFitParams& params);

// How far the enclosing step pushes each point outward: its position uncertainty, 3 sigma of range noise plus
// half a voxel diagonal. Who checks that a point is enclosed (the tracker's deferred refits, the tests and the
// bench) pushes it by the same amount.
double enclosingMargin(double range_noise_sigma, double voxel_size, int dimensions);

// The same fit on support points whose bearings are already known (the tracker's refit).
ObstacleEllipsoid fitEllipsoid(std::span<const SupportPoint> support, int dimensions,
                               const EllipsoidFitParams& params);

// Principal axes of points[indices] (all when empty) as the columns of a proper rotation, largest
// spread first; in 2-D (dimensions 2) the third column is +z and only x, y are used.
Eigen::Matrix3f principalAxes(std::span<const Eigen::Vector3f> points, std::span<const int> indices,
                              int dimensions);

// Bounds the size of one obstacle piece: appends to `out` pieces of points[indices] that are boxes
// of at most max_length along every principal axis and at most max_width along the thinnest one
// (or at most max_width along all of them: a small blob). A bigger piece is cut across its longest
// principal extent into max(2, ceil(extent / max_length)) equal slabs and every slab is split
// again (depth-limited at 24 levels; a single point is never split). So a wall becomes a chain of
// thin pieces and an L of two faces is halved into two nearly straight ones. max_length <= 0:
// `indices` is appended unchanged; max_width <= 0 means max_length. Pieces keep the given order.
void splitByExtent(std::span<const Eigen::Vector3f> points, std::span<const int> indices, int dimensions,
                   double max_length, double max_width, Clusters& out);

// The rule of splitByExtent for a piece with these extents along its principal axes (largest
// first, thinnest last).
bool pieceTooBig(const Eigen::Vector3f& extent, int dimensions, float max_length, float max_width);

// Recomputes semi_axes, axes and orientation of `e` from its covariance and probability.
void updateShapeFromCovariance(ObstacleEllipsoid& e);

}  // namespace ddsnav::perception
